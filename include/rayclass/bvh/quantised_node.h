// The 8-wide hierarchy's nodes as the kernels read them (RcBvh8QNode, rc_types.h): child boxes
// rounded outward to a grid of 8-bit steps over the node's box (Ylitie et al. 2017 compress
// wide nodes the same way), so that a walk fetches two cache lines per node instead of four.
#pragma once

#include "rc_types.h"

namespace rayclass::bvh {

// `node` with each child box replaced by the smallest grid box that holds it in the floats a
// kernel computes from the grid (RcBvh8QNode), the child references and count unchanged.
RcBvh8QNode Quantise(const RcBvh8Node& node);

}  // namespace rayclass::bvh
