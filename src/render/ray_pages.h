// A generation's rays as the renderer keeps them: on the device in pages of one batch each,
// and on the host only each ray's pixel, for accumulating its contributions.
#pragma once

#include <cstdint>
#include <vector>

#include "rayclass/render/buffers.h"
#include "rayclass/render/launch.h"
#include "rc_types.h"

namespace rayclass::render {

struct RayPages {
    std::vector<RayBuffers> pages;
    std::vector<uint32_t> pixels;
};

// Device pages of rays (both arrays), recycled from generation to generation: a fresh buffer
// costs its page faults again.
class PagePool {
  public:
    PagePool(clrt::Context& ctx, size_t pageRays) : ctx_(ctx), pageRays_(pageRays) {}
    size_t PageRays() const { return pageRays_; }
    RayBuffers Take() {
        if (free_.empty()) {
            return {DeviceBuffer(ctx_, pageRays_ * sizeof(RcRay)),
                    DeviceBuffer(ctx_, pageRays_ * sizeof(RcRayInfo))};
        }
        RayBuffers page = std::move(free_.back());
        free_.pop_back();
        return page;
    }
    void Give(RayBuffers& page) {
        if (page.rays()) free_.push_back(std::move(page));
        page = RayBuffers();
    }
    void Give(std::vector<RayBuffers>& pages) {
        for (RayBuffers& page : pages) Give(page);
        pages.clear();
    }

  private:
    clrt::Context& ctx_;
    size_t pageRays_;
    std::vector<RayBuffers> free_;
};

}  // namespace rayclass::render
