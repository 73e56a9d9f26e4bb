#include "rayclass/scene/patch.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <queue>
#include <sstream>

#include "rayclass/core/error.h"
#include "text_input.h"

namespace rayclass::scene {

namespace {

using Row = std::vector<glm::dvec4>;

// One degree elevation of a Bezier curve: degree n to n + 1.
Row Elevate(const Row& c) {
    const size_t n = c.size() - 1;
    Row out(n + 2);
    out[0] = c[0];
    out[n + 1] = c[n];
    for (size_t i = 1; i <= n; ++i) {
        const double a = double(i) / double(n + 1);
        out[i] = a * c[i - 1] + (1.0 - a) * c[i];
    }
    return out;
}

Row ToCubic(Row c) {
    while (c.size() < 4) c = Elevate(c);
    return c;
}

// The grid's rows (fixed i) or columns (fixed j) of an nu x nv grid as curves.
std::vector<Row> Curves(const std::vector<glm::dvec4>& p, size_t nu, size_t nv, bool alongU) {
    std::vector<Row> out(alongU ? nv : nu);
    for (size_t i = 0; i < nu; ++i) {
        for (size_t j = 0; j < nv; ++j) (alongU ? out[j] : out[i]).push_back(p[i * nv + j]);
    }
    return out;
}

// Inserts knots until every interior knot has multiplicity `degree` (Boehm's insertion), so the
// curve's points fall into Bezier segments of degree + 1 points sharing their ends.
void ToBezierSegments(std::vector<double>& knots, std::vector<Row>& curves, int degree) {
    const int p = degree;
    for (size_t k = size_t(p) + 1; k + size_t(p) + 1 < knots.size();) {
        const double u = knots[k];
        size_t mult = 0;
        while (k + mult < knots.size() && knots[k + mult] == u) ++mult;
        for (size_t r = mult; r < size_t(p); ++r) {
            // u sits in span [knots[s], knots[s + 1]) with s the last index of its run.
            const size_t s = k + r - 1;
            for (Row& c : curves) {
                Row q(c.size() + 1);
                for (size_t i = 0; i < q.size(); ++i) {
                    if (i + size_t(p) <= s) {
                        q[i] = c[i];
                    } else if (i > s) {
                        q[i] = c[i - 1];
                    } else {
                        const double a = (u - knots[i]) / (knots[i + size_t(p)] - knots[i]);
                        q[i] = (1.0 - a) * c[i - 1] + a * c[i];
                    }
                }
                c = std::move(q);
            }
            knots.insert(knots.begin() + std::ptrdiff_t(k), u);
        }
        k += std::max(mult, size_t(p));
    }
}

[[noreturn]] void FailAt(const std::filesystem::path& file, int line, std::string problem) {
    throw SceneError(file.string(), line, std::move(problem));
}

bool ParseInt(std::string_view token, int& value) {
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    return ec == std::errc() && end == token.data() + token.size();
}

double Distance(const glm::dvec3& a, const glm::dvec3& b) { return glm::length(a - b); }
glm::dvec3 Euclid(const glm::dvec4& h) { return glm::dvec3(h) / h.w; }

}  // namespace

Patch ToBicubic(const BezierNet& net) {
    const size_t nu = size_t(net.du) + 1, nv = size_t(net.dv) + 1;
    std::vector<Row> columns;  // per i: the curve along v, raised to degree 3
    for (size_t i = 0; i < nu; ++i) {
        columns.push_back(ToCubic(Row(net.p.begin() + std::ptrdiff_t(i * nv),
                                      net.p.begin() + std::ptrdiff_t((i + 1) * nv))));
    }
    Patch patch;
    for (size_t j = 0; j < 4; ++j) {
        Row along;
        for (size_t i = 0; i < nu; ++i) along.push_back(columns[i][j]);
        const Row cubic = ToCubic(along);
        for (size_t i = 0; i < 4; ++i) patch.p[i * 4 + j] = cubic[i];
    }
    return patch;
}

std::string KnotProblem(const std::vector<double>& knots, int degree, size_t points) {
    const size_t p = size_t(degree);
    if (points < p + 1) {
        return "must allow at least " + std::to_string(p + 1) + " control points for degree " +
               std::to_string(degree);
    }
    if (knots.size() != points + p + 1) {
        return "must hold " + std::to_string(points + p + 1) + " knots (control points + degree " +
               "+ 1), not " + std::to_string(knots.size());
    }
    for (double k : knots) {
        if (!std::isfinite(k)) return "must be finite numbers";
    }
    for (size_t i = 1; i < knots.size(); ++i) {
        if (knots[i] < knots[i - 1]) {
            return "must be non-decreasing (knot " + std::to_string(i + 1) + " is below knot " +
                   std::to_string(i) + ")";
        }
    }
    for (size_t i = 1; i <= p; ++i) {
        if (knots[i] != knots[0] || knots[knots.size() - 1 - i] != knots.back()) {
            return "must be clamped (each end repeated degree + 1 = " + std::to_string(p + 1) +
                   " times)";
        }
    }
    if (!(knots.back() > knots.front())) return "must span a non-empty interval";
    for (size_t i = p + 1; i + p + 1 < knots.size(); ++i) {
        size_t mult = 1;
        while (i + mult + p + 1 < knots.size() && knots[i + mult] == knots[i]) ++mult;
        if (mult > p) {
            std::ostringstream knot;
            knot << knots[i];
            return "must not repeat interior knot " + knot.str() + " more often than the degree (" +
                   std::to_string(degree) + ")";
        }
        i += mult - 1;
    }
    return {};
}

std::vector<BezierNet> NurbsToBezier(const Nurbs& n) {
    const size_t nu = n.knotsU.size() - size_t(n.du) - 1, nv = n.knotsV.size() - size_t(n.dv) - 1;
    // Along u: one curve per j; then each refined grid's curves along v.
    std::vector<double> ku = n.knotsU, kv = n.knotsV;
    std::vector<Row> alongU = Curves(n.p, nu, nv, true);
    ToBezierSegments(ku, alongU, n.du);
    const size_t nu2 = alongU[0].size();
    std::vector<glm::dvec4> grid(nu2 * nv);
    for (size_t i = 0; i < nu2; ++i) {
        for (size_t j = 0; j < nv; ++j) grid[i * nv + j] = alongU[j][i];
    }
    std::vector<Row> alongV = Curves(grid, nu2, nv, false);
    ToBezierSegments(kv, alongV, n.dv);
    const size_t nv2 = alongV[0].size();
    const size_t su = (nu2 - 1) / size_t(n.du), sv = (nv2 - 1) / size_t(n.dv);
    std::vector<BezierNet> out;
    for (size_t a = 0; a < su; ++a) {
        for (size_t b = 0; b < sv; ++b) {
            BezierNet net{n.du, n.dv, {}};
            for (size_t i = 0; i <= size_t(n.du); ++i) {
                for (size_t j = 0; j <= size_t(n.dv); ++j) {
                    net.p.push_back(alongV[a * size_t(n.du) + i][b * size_t(n.dv) + j]);
                }
            }
            out.push_back(std::move(net));
        }
    }
    return out;
}

std::vector<BezierNet> ParseBpt(std::string_view text, const std::filesystem::path& file) {
    LineReader lines(text);
    std::string_view line;
    int lineNumber = 0;
    if (!lines.Next(line, lineNumber)) FailAt(file, 0, "empty file (expected the patch count)");
    std::string_view rest = line;
    int count = 0;
    if (!ParseInt(NextToken(rest), count) || count < 1 || !NextToken(rest).empty()) {
        FailAt(file, lineNumber, "the first line must be the patch count, a positive integer");
    }
    std::vector<BezierNet> nets;
    for (int k = 1; k <= count; ++k) {
        const std::string patch = "patch " + std::to_string(k);
        if (!lines.Next(line, lineNumber)) {
            FailAt(file, lines.PhysicalLines(),
                   "truncated: " + patch + " of " + std::to_string(count) + " is missing");
        }
        rest = line;
        BezierNet net;
        if (!ParseInt(NextToken(rest), net.du) || !ParseInt(NextToken(rest), net.dv) ||
            !NextToken(rest).empty() || net.du < 1 || net.du > 3 || net.dv < 1 || net.dv > 3) {
            FailAt(file, lineNumber,
                   patch + ": the degree line must be two integers 1..3 (degrees in u and v)");
        }
        const int points = (net.du + 1) * (net.dv + 1);
        for (int i = 0; i < points; ++i) {
            if (!lines.Next(line, lineNumber)) {
                FailAt(file, lines.PhysicalLines(),
                       "truncated: " + patch + " has " + std::to_string(i) + " of its " +
                           std::to_string(points) + " points");
            }
            rest = line;
            float xyz[3];
            for (float& c : xyz) {
                const std::string_view token = NextToken(rest);
                const NumberStatus status = ParseFloat(token, c);
                if (status == NumberStatus::kNonFinite) {
                    FailAt(file, lineNumber,
                           patch + ": non-finite coordinate '" + std::string(token) + "'");
                }
                if (status != NumberStatus::kOk || std::fabs(c) > kMaxCoordinate) {
                    FailAt(file, lineNumber,
                           patch +
                               ": a point must be three finite numbers of magnitude at most "
                               "1e12 (got '" +
                               std::string(line) + "')");
                }
            }
            if (!NextToken(rest).empty()) {
                FailAt(file, lineNumber, patch + ": a point line holds three numbers only");
            }
            net.p.emplace_back(xyz[0], xyz[1], xyz[2], 1.0);
        }
        nets.push_back(std::move(net));
    }
    if (lines.Next(line, lineNumber)) {
        FailAt(file, lineNumber,
               "more data after the " + std::to_string(count) + " patches the first line counts");
    }
    return nets;
}

double PatchDeviation(const std::array<glm::dvec4, 16>& p) {
    const glm::dvec3 c00 = Euclid(p[0]), c03 = Euclid(p[3]), c30 = Euclid(p[12]),
                     c33 = Euclid(p[15]);
    Bounds3d box;
    double worst = 0.0;
    for (int i = 0; i < 4; ++i) {
        for (int j = 0; j < 4; ++j) {
            const double s = i / 3.0, t = j / 3.0;
            const glm::dvec3 bilinear =
                (1 - s) * ((1 - t) * c00 + t * c03) + s * ((1 - t) * c30 + t * c33);
            const glm::dvec3 q = Euclid(p[size_t(i * 4 + j)]);
            worst = std::max(worst, Distance(q, bilinear));
            box.Grow(q);
        }
    }
    const double diagonal = box.Diagonal();
    return diagonal > 0.0 ? worst / diagonal : 0.0;
}

std::array<std::array<glm::dvec4, 16>, 2> HalvePatch(const std::array<glm::dvec4, 16>& p,
                                                     bool alongU) {
    std::array<std::array<glm::dvec4, 16>, 2> out;
    for (int line = 0; line < 4; ++line) {
        // The curve of this line along the split direction.
        auto at = [&](int k) { return size_t(alongU ? k * 4 + line : line * 4 + k); };
        glm::dvec4 c[4] = {p[at(0)], p[at(1)], p[at(2)], p[at(3)]};
        const glm::dvec4 a = 0.5 * (c[0] + c[1]), b = 0.5 * (c[1] + c[2]), d = 0.5 * (c[2] + c[3]);
        const glm::dvec4 ab = 0.5 * (a + b), bd = 0.5 * (b + d), m = 0.5 * (ab + bd);
        const glm::dvec4 left[4] = {c[0], a, ab, m}, right[4] = {m, bd, d, c[3]};
        for (int k = 0; k < 4; ++k) {
            out[0][at(k)] = left[k];
            out[1][at(k)] = right[k];
        }
    }
    return out;
}

Bounds3f ControlBounds(const std::array<glm::dvec4, 16>& p) {
    Bounds3d box;
    for (const auto& h : p) box.Grow(Euclid(h));
    Bounds3f f;
    for (int a = 0; a < 3; ++a) {
        f.lo[a] = std::nextafter(float(box.lo[a]), -INFINITY);
        f.hi[a] = std::nextafter(float(box.hi[a]), INFINITY);
    }
    return f;
}

void SplitPatches(Scene& scene, const PatchSplit& split) {
    scene.patchBoxes.clear();
    for (uint32_t k = 0; k < scene.patches.size(); ++k) {
        PatchBox whole;
        whole.p = scene.patches[k].p;
        whole.patch = k;
        const uint32_t target = split.boxesPerPatch > 0 ? split.boxesPerPatch : kMaxFlatnessBoxes;
        // Least flat first; with no fixed count only boxes above the flatness bound are halved.
        auto less = [](const std::pair<double, PatchBox>& a, const std::pair<double, PatchBox>& b) {
            return a.first < b.first;
        };
        std::priority_queue<std::pair<double, PatchBox>, std::vector<std::pair<double, PatchBox>>,
                            decltype(less)>
            queue(less);
        queue.push({PatchDeviation(whole.p), whole});
        std::vector<PatchBox> done;
        while (!queue.empty() && queue.size() + done.size() < target) {
            auto [deviation, box] = queue.top();
            if (split.boxesPerPatch == 0 && deviation <= double(split.flatness)) break;
            queue.pop();
            const bool canU = box.u[1] - box.u[0] > kMinPatchExtent;
            const bool canV = box.v[1] - box.v[0] > kMinPatchExtent;
            if (!canU && !canV) {
                done.push_back(box);
                continue;
            }
            // Halve where the halves come out flatter (across a patch's long side; around a
            // collapsed edge, where halving towards the point only makes smaller copies).
            const auto byU = HalvePatch(box.p, true), byV = HalvePatch(box.p, false);
            const double du = std::max(PatchDeviation(byU[0]), PatchDeviation(byU[1]));
            const double dv = std::max(PatchDeviation(byV[0]), PatchDeviation(byV[1]));
            const bool alongU = canU && (!canV || du <= dv);
            const auto& halves = alongU ? byU : byV;
            for (int h = 0; h < 2; ++h) {
                PatchBox part = box;
                part.p = halves[size_t(h)];
                glm::dvec2& range = alongU ? part.u : part.v;
                const double mid = 0.5 * (range[0] + range[1]);
                range = h == 0 ? glm::dvec2(range[0], mid) : glm::dvec2(mid, range[1]);
                bool& closed = alongU ? part.closedU : part.closedV;
                closed = h == 1 && closed;
                queue.push({PatchDeviation(part.p), part});
            }
        }
        while (!queue.empty()) {
            done.push_back(queue.top().second);
            queue.pop();
        }
        // A fixed order (by parameter range) whatever the queue's: ids follow it.
        std::sort(done.begin(), done.end(), [](const PatchBox& a, const PatchBox& b) {
            return a.u[0] != b.u[0] ? a.u[0] < b.u[0] : a.v[0] < b.v[0];
        });
        for (PatchBox& box : done) {
            box.bounds = ControlBounds(box.p);
            scene.patchBoxes.push_back(box);
        }
    }
}

}  // namespace rayclass::scene
