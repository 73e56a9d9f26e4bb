#include "core.h"

namespace rayclass::classify {

namespace {

Bounds3f PaddedSceneBox(const scene::Scene& scene, float padding) {
    Bounds3f box = scene.Bounds();
    if (!box.Empty()) {
        box.lo -= glm::vec3(padding);
        box.hi += glm::vec3(padding);
    }
    return box;
}

std::vector<Node> FaceRoots(const Bounds3f& sceneBox) {
    std::vector<Node> roots(kFaceCount);
    for (int face = 0; face < kFaceCount; ++face) {
        roots[size_t(face)].box = BoxInFace(face, sceneBox);
        roots[size_t(face)].face = uint8_t(face);
    }
    return roots;
}

}  // namespace

Core::Core(const scene::Scene& s, const Params& p)
    : scene(s),
      params(p),
      sceneBox(PaddedSceneBox(s, p.padding)),
      nodes(FaceRoots(sceneBox)),
      faceLists(BuildFaceLists(s, p)),
      cost(s, params, sceneBox),
      pool(nodes, params) {}

Core::Core(const Core& other)
    : scene(other.scene),
      params(other.params),
      sceneBox(other.sceneBox),
      nodes(other.nodes),
      faceLists(other.faceLists),
      cost(other.scene, params, sceneBox),
      pool(nodes, params),
      counters(other.counters) {}

uint32_t Core::Route(const Ray5& r) const {
    uint32_t node = uint32_t(r.face);
    while (!nodes[node].IsLeaf()) {
        const Node& n = nodes[node];
        if (nodes[n.child[0]].box.Contains(r.p)) {
            node = n.child[0];
        } else if (nodes[n.child[1]].box.Contains(r.p)) {
            node = n.child[1];
        } else if (n.remainder != kNoNode) {
            node = n.remainder;
        } else {
            return kNoNode;
        }
    }
    return node;
}

void Core::Reset() {
    nodes.resize(kFaceCount);
    for (Node& n : nodes) n.child[0] = n.child[1] = n.remainder = kNoNode;
}

size_t Core::MemoryBytes() const {
    return nodes.capacity() * sizeof(Node) + faceLists->Bytes() + counters.scratchBytes;
}

}  // namespace rayclass::classify
