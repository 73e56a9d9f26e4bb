// A buffer's first elements mapped for reading on the host: no copy on a device that shares host
// memory (PoCL on the CPU), a transfer on any other. Unmapped by Unmap(), which reports errors,
// or else when it goes out of scope (an error path, where a destructor cannot report one).
#pragma once

#include <cstddef>
#include <span>

#include "rayclass/clrt/context.h"

namespace rayclass::clrt {

template <typename T>
class MappedRead {
  public:
    // Blocks until the elements [0, n) of `buffer` can be read; n == 0 maps nothing.
    MappedRead(const cl::CommandQueue& queue, const cl::Buffer& buffer, size_t n)
        : queue_(queue), buffer_(buffer), n_(n) {
        if (n_ == 0) return;
        data_ = static_cast<const T*>(Check("clEnqueueMapBuffer", [&] {
            return queue_.enqueueMapBuffer(buffer_, CL_TRUE, CL_MAP_READ, 0, n_ * sizeof(T));
        }));
    }
    MappedRead(const MappedRead&) = delete;
    MappedRead& operator=(const MappedRead&) = delete;
    ~MappedRead() {
        if (data_)
            clEnqueueUnmapMemObject(queue_(), buffer_(), const_cast<T*>(data_), 0, nullptr,
                                    nullptr);
    }

    const T* data() const { return data_; }
    std::span<const T> span() const { return {data_, data_ ? n_ : 0}; }

    // Enqueues the unmap; commands enqueued after it on the same queue see the buffer again.
    void Unmap() {
        if (!data_) return;
        const T* data = data_;
        data_ = nullptr;
        Check("clEnqueueUnmapMemObject",
              [&] { queue_.enqueueUnmapMemObject(buffer_, const_cast<T*>(data)); });
    }

  private:
    cl::CommandQueue queue_;
    cl::Buffer buffer_;
    size_t n_;
    const T* data_ = nullptr;
};

}  // namespace rayclass::clrt
