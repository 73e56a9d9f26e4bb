#include "rayclass/image/merge.h"

#include <algorithm>
#include <limits>

#include "rayclass/core/error.h"
#include "rayclass/image/tiles.h"

namespace rayclass::image {

namespace {

PixelRect PlaceOf(const Image& img) {
    return {img.originX, img.originY, img.originX + img.width, img.originY + img.height};
}

std::string Layers(const Image& img) {
    std::string s = "R,G,B";
    if (!img.depth.empty()) s += ",depth.Z";
    if (!img.id.empty()) s += ",id.ID";
    if (!img.normal.empty()) s += ",normal.X,normal.Y,normal.Z";
    return s;
}

std::string SizeOf(const Image& img) {
    return std::to_string(img.DisplayWidth()) + "x" + std::to_string(img.DisplayHeight());
}

// Every tile of the same image as the first: display window, layers and scene hash.
void CheckSameImage(const std::vector<NamedTile>& tiles) {
    const NamedTile& first = tiles.front();
    for (const NamedTile& t : tiles) {
        const Image &a = first.image, &b = t.image;
        if (a.DisplayWidth() != b.DisplayWidth() || a.DisplayHeight() != b.DisplayHeight()) {
            throw Error(t.name + ": part of a " + SizeOf(b) + " image, " + first.name + " of a " +
                        SizeOf(a) + " one");
        }
        if (Layers(a) != Layers(b)) {
            throw Error(t.name + ": layers " + Layers(b) + " differ from " + first.name + "'s " +
                        Layers(a));
        }
        if (a.sceneHash != b.sceneHash) {
            throw Error(t.name + ": rendered from another scene or options than " + first.name +
                        " (scene hash " + (b.sceneHash.empty() ? "none" : b.sceneHash) + " vs " +
                        (a.sceneHash.empty() ? "none" : a.sceneHash) + ")");
        }
    }
}

void CheckNoOverlap(const std::vector<NamedTile>& tiles) {
    for (size_t i = 0; i < tiles.size(); ++i) {
        for (size_t j = i + 1; j < tiles.size(); ++j) {
            const PixelRect a = PlaceOf(tiles[i].image), b = PlaceOf(tiles[j].image);
            if (a.Overlaps(b)) {
                throw Error(tiles[j].name + " (pixels " + b.ToString() + ") overlaps " +
                            tiles[i].name + " (pixels " + a.ToString() + ")");
            }
        }
    }
}

// The rectangles no tile covers, on the grid of the tiles' edges, each run of uncovered cells of
// a grid row as one rectangle.
std::vector<PixelRect> Uncovered(const std::vector<NamedTile>& tiles, uint32_t w, uint32_t h) {
    std::vector<uint32_t> xs{0, w}, ys{0, h};
    for (const NamedTile& t : tiles) {
        const PixelRect r = PlaceOf(t.image);
        xs.insert(xs.end(), {r.x0, r.x1});
        ys.insert(ys.end(), {r.y0, r.y1});
    }
    for (auto* v : {&xs, &ys}) {
        std::sort(v->begin(), v->end());
        v->erase(std::unique(v->begin(), v->end()), v->end());
    }
    auto covered = [&](uint32_t x, uint32_t y) {
        return std::any_of(tiles.begin(), tiles.end(), [&](const NamedTile& t) {
            const PixelRect r = PlaceOf(t.image);
            return x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1;
        });
    };
    std::vector<PixelRect> missing;
    for (size_t j = 0; j + 1 < ys.size(); ++j) {
        for (size_t i = 0; i + 1 < xs.size(); ++i) {
            if (covered(xs[i], ys[j])) continue;
            if (!missing.empty() && missing.back().y0 == ys[j] && missing.back().x1 == xs[i]) {
                missing.back().x1 = xs[i + 1];  // the run goes on
            } else {
                missing.push_back({xs[i], ys[j], xs[i + 1], ys[j + 1]});
            }
        }
    }
    return missing;
}

void CheckCovered(const std::vector<NamedTile>& tiles, uint32_t w, uint32_t h) {
    const std::vector<PixelRect> missing = Uncovered(tiles, w, h);
    if (missing.empty()) return;
    std::string list;
    for (size_t k = 0; k < missing.size() && k < 8; ++k) {
        list += (k ? "; " : "") + missing[k].ToString();
    }
    if (missing.size() > 8) list += "; and " + std::to_string(missing.size() - 8) + " more";
    throw Error("no tile covers pixels " + list + " of the " + std::to_string(w) + "x" +
                std::to_string(h) + " image (--allow-partial merges anyway)");
}

// Copies the rows of `tile`'s layer `from` into `to`'s, at the tile's place (none: an absent
// layer).
template <typename T>
void Place(const std::vector<T>& from, const Image& tile, std::vector<T>& to, uint32_t width) {
    if (from.empty()) return;
    for (uint32_t y = 0; y < tile.height; ++y) {
        std::copy_n(from.begin() + ptrdiff_t(size_t(y) * tile.width), tile.width,
                    to.begin() + ptrdiff_t(size_t(tile.originY + y) * width + tile.originX));
    }
}

}  // namespace

Image MergeTiles(const std::vector<NamedTile>& tiles, bool allowPartial) {
    if (tiles.empty()) throw Error("no tiles to merge");
    CheckSameImage(tiles);
    CheckNoOverlap(tiles);
    const Image& first = tiles.front().image;
    const uint32_t w = first.DisplayWidth(), h = first.DisplayHeight();
    if (!allowPartial) CheckCovered(tiles, w, h);
    Image out(w, h);
    out.sceneHash = first.sceneHash;
    if (!first.depth.empty()) {
        out.depth.assign(out.PixelCount(), std::numeric_limits<float>::infinity());
    }
    if (!first.id.empty()) out.id.assign(out.PixelCount(), 0xFFFFFFFFu);
    if (!first.normal.empty()) out.normal.assign(out.PixelCount(), glm::vec3(0.0f));
    for (const NamedTile& t : tiles) {
        Place(t.image.rgb, t.image, out.rgb, w);
        Place(t.image.depth, t.image, out.depth, w);
        Place(t.image.id, t.image, out.id, w);
        Place(t.image.normal, t.image, out.normal, w);
    }
    return out;
}

}  // namespace rayclass::image
