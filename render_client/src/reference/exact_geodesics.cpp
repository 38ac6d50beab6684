#include "render_client/reference/exact_geodesics.h"

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <limits>
#include <numbers>
#include <queue>
#include <unordered_map>

namespace holofuse::render::reference {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr uint32_t kNoFace = std::numeric_limits<uint32_t>::max();
// Rays exactly through a vertex (collinear vertices on regular meshes) must
// count as inside both wedges the vertex splits: directions are compared
// with this relative slack.
constexpr double kAngleSlack = 1e-12;

double cross(const glm::dvec2& u, const glm::dvec2& v) { return u.x * v.y - u.y * v.x; }

// u is counter-clockwise of v, or on it within the slack.
bool notClockwiseOf(const glm::dvec2& u, const glm::dvec2& v) {
  return cross(v, u) >= -kAngleSlack * glm::length(u) * glm::length(v);
}

double segmentDistanceFromOrigin(const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 e = b - a;
  const double l2 = glm::dot(e, e);
  const double t = l2 > 0 ? std::clamp(-glm::dot(a, e) / l2, 0.0, 1.0) : 0.0;
  return glm::length(a + t * e);
}

uint64_t edgeKey(uint32_t a, uint32_t b) {
  return (uint64_t{std::min(a, b)} << 32) | std::max(a, b);
}

struct Topology {
  std::unordered_map<uint64_t, std::vector<uint32_t>> edge_faces;
  std::vector<uint32_t> face_offsets, faces_of_vertex;  // CSR vertex -> faces

  explicit Topology(const Mesh& mesh) {
    const size_t n = mesh.vertexCount();
    face_offsets.assign(n + 1, 0);
    for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = mesh.indices[3 * t + k], b = mesh.indices[3 * t + (k + 1) % 3];
        edge_faces[edgeKey(a, b)].push_back(t);
        ++face_offsets[a + 1];
      }
    }
    for (size_t v = 0; v < n; ++v) face_offsets[v + 1] += face_offsets[v];
    faces_of_vertex.resize(face_offsets[n]);
    std::vector<uint32_t> fill(face_offsets.begin(), face_offsets.end() - 1);
    for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
      for (int k = 0; k < 3; ++k) faces_of_vertex[fill[mesh.indices[3 * t + k]]++] = t;
    }
  }

  // The triangle across edge (a, b) from `from`; none on a boundary or a
  // non-manifold edge.
  uint32_t across(uint32_t a, uint32_t b, uint32_t from) const {
    const auto it = edge_faces.find(edgeKey(a, b));
    if (it == edge_faces.end() || it->second.size() != 2) return kNoFace;
    return it->second[0] == from ? it->second[1] : it->second[0];
  }
};

// A wedge of straight rays from the origin (the beam's source, unfolded),
// about to cross mesh edge (a, b) out of triangle `from`. In the unfolded
// plane a sits at pa on the clockwise side and b at pb on the
// counter-clockwise side; the rays run from direction `right` counter-
// clockwise to `left`.
struct Beam {
  uint32_t a, b, from;
  glm::dvec2 pa, pb, right, left;
};

class BeamCaster {
 public:
  BeamCaster(const Mesh& mesh, const Topology& topology) : mesh_(mesh), topology_(topology) {}

  // Every straight unfolded line from vertex p shorter than `budget`
  // offers its length to `reach(vertex, length)`.
  template <typename Reach>
  void cast(uint32_t p, double budget, Reach&& reach) {
    stack_.clear();
    for (uint32_t k = topology_.face_offsets[p]; k < topology_.face_offsets[p + 1]; ++k) {
      const uint32_t t = topology_.faces_of_vertex[k];
      const uint32_t* tri = &mesh_.indices[3 * t];
      const int corner = tri[0] == p ? 0 : (tri[1] == p ? 1 : 2);
      const uint32_t u = tri[(corner + 1) % 3], w = tri[(corner + 2) % 3];
      if (u == p || w == p) continue;  // degenerate triangle
      const glm::dvec3 pp = position(p), eu = position(u) - pp, ew = position(w) - pp;
      const double lu = glm::length(eu), lw = glm::length(ew);
      if (!(lu > 0) || !(lw > 0)) continue;
      const double angle = std::acos(std::clamp(glm::dot(eu, ew) / (lu * lw), -1.0, 1.0));
      reach(u, lu);
      reach(w, lw);
      if (!(angle > 0) || !(angle < std::numbers::pi)) continue;
      const glm::dvec2 pu(lu, 0.0), pw(lw * std::cos(angle), lw * std::sin(angle));
      stack_.push_back({u, w, t, pu, pw, pu, pw});
    }
    while (!stack_.empty()) {
      const Beam beam = stack_.back();
      stack_.pop_back();
      step(beam, budget, reach);
    }
  }

 private:
  glm::dvec3 position(uint32_t v) const { return glm::dvec3(mesh_.positions[v]); }

  template <typename Reach>
  void step(const Beam& beam, double budget, Reach&& reach) {
    // Only the rays that pass through the edge segment itself go on.
    const glm::dvec2 right = notClockwiseOf(beam.pa, beam.right) ? beam.pa : beam.right;
    const glm::dvec2 left = notClockwiseOf(beam.left, beam.pb) ? beam.pb : beam.left;
    if (cross(right, left) <= kAngleSlack * glm::length(right) * glm::length(left)) return;
    if (segmentDistanceFromOrigin(beam.pa, beam.pb) > budget) return;
    const uint32_t g = topology_.across(beam.a, beam.b, beam.from);
    if (g == kNoFace) return;
    const uint32_t* tri = &mesh_.indices[3 * g];
    uint32_t c = tri[0];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] != beam.a && tri[k] != beam.b) c = tri[k];
    }
    if (c == beam.a || c == beam.b) return;  // degenerate triangle
    // Unfold c across the edge, on the far side from the origin.
    const double ac = glm::length(position(c) - position(beam.a));
    const double bc = glm::length(position(c) - position(beam.b));
    const glm::dvec2 e = beam.pb - beam.pa;
    const double l = glm::length(e);
    if (!(l > 0)) return;
    const double x = (ac * ac - bc * bc + l * l) / (2 * l);
    const double y = std::sqrt(std::max(ac * ac - x * x, 0.0));
    glm::dvec2 normal(-e.y / l, e.x / l);
    if (glm::dot(normal, -beam.pa) > 0) normal = -normal;
    const glm::dvec2 pc = beam.pa + e * (x / l) + normal * y;
    const bool past_right = notClockwiseOf(pc, right), before_left = notClockwiseOf(left, pc);
    if (past_right && before_left) {
      // c is in sight: a straight line; the wedge splits around it.
      reach(c, glm::length(pc));
      stack_.push_back({beam.a, c, g, beam.pa, pc, right, pc});
      stack_.push_back({c, beam.b, g, pc, beam.pb, pc, left});
    } else if (!past_right) {
      stack_.push_back({c, beam.b, g, pc, beam.pb, right, left});  // c lies clockwise of every ray
    } else {
      stack_.push_back(
          {beam.a, c, g, beam.pa, pc, right, left});  // c lies counter-clockwise of every ray
    }
  }

  const Mesh& mesh_;
  const Topology& topology_;
  std::vector<Beam> stack_;
};

}  // namespace

std::vector<uint8_t> bendVertices(const Mesh& mesh) {
  const size_t n = mesh.vertexCount();
  std::vector<double> angle_sum(n, 0.0);
  std::vector<uint8_t> bend(n, 0);
  std::unordered_map<uint64_t, int> edge_uses;
  for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = mesh.indices[3 * t + k], u = mesh.indices[3 * t + (k + 1) % 3],
                     w = mesh.indices[3 * t + (k + 2) % 3];
      ++edge_uses[edgeKey(p, u)];
      const glm::dvec3 eu = glm::dvec3(mesh.positions[u]) - glm::dvec3(mesh.positions[p]);
      const glm::dvec3 ew = glm::dvec3(mesh.positions[w]) - glm::dvec3(mesh.positions[p]);
      const double lu = glm::length(eu), lw = glm::length(ew);
      if (lu > 0 && lw > 0)
        angle_sum[p] += std::acos(std::clamp(glm::dot(eu, ew) / (lu * lw), -1.0, 1.0));
    }
  }
  for (const auto& [key, uses] : edge_uses) {
    if (uses != 2) bend[key >> 32] = bend[key & 0xffffffffu] = 1;
  }
  for (size_t v = 0; v < n; ++v) {
    if (angle_sum[v] > 2 * std::numbers::pi * (1 + 1e-9)) bend[v] = 1;
  }
  return bend;
}

std::vector<double> exactGeodesic(const Mesh& mesh, const std::vector<uint8_t>& is_source,
                                  double max_distance) {
  const size_t n = mesh.vertexCount();
  const Topology topology(mesh);
  const std::vector<uint8_t> bend = bendVertices(mesh);
  std::vector<double> distance(n, kInf);
  std::vector<uint8_t> settled(n, 0);
  using Item = std::pair<double, uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (uint32_t v = 0; v < n; ++v) {
    if (v < is_source.size() && is_source[v]) {
      distance[v] = 0.0;
      queue.emplace(0.0, v);
    }
  }
  BeamCaster caster(mesh, topology);
  while (!queue.empty()) {
    const auto [d, p] = queue.top();
    queue.pop();
    if (settled[p] || d > distance[p]) continue;
    settled[p] = 1;
    // Straight lines cannot pass through a vertex with angle sum below
    // 2 pi, nor usefully bend there: only sources and bend vertices cast.
    if (distance[p] > 0 && !bend[p]) continue;
    caster.cast(p, max_distance - d, [&, d = d](uint32_t v, double length) {
      const double candidate = d + length;
      if (candidate <= max_distance && candidate < distance[v]) {
        distance[v] = candidate;
        queue.emplace(candidate, v);
      }
    });
  }
  return distance;
}

}  // namespace holofuse::render::reference
