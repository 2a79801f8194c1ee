// Open-border caps: let meshopt 0.18 simplify the mesh's own open borders while its
// LockBorder still locks the group border (spec/dag.md §2.3 Locks: only group borders are
// locked). 0.18 has no per-vertex locks: LockBorder locks every vertex of the sub-mesh's
// topological border, which is the group border *and* the mesh's holes, so meshes with holes
// kept every hole vertex at every level and their coarse levels stopped halving. Here each
// chain of open edges that belong to this group alone (an open edge with an unlocked end) is
// closed by a fan of temporary "cap" triangles to one apex vertex per chain, built on copies
// of the chain's vertices at the same positions: to meshopt each unlocked chain vertex is then
// a seam (two wedges whose open edges run opposite), which may collapse only along the chain
// onto the next chain vertex, as a border vertex of its own border would; the apex and the
// chain's ends (group-border vertices; their copies are a few ulps off, so no wedge) stay on
// the sub-mesh border and so stay locked. The apex stands above the chain along its faces'
// normal, so each cap triangle is near the plane through its border edge perpendicular to the
// surface: its quadric charges a collapse for moving the border across the hole. After
// simplification the cap triangles are removed and the result is accepted only if it is a
// valid simplification of the real surface whose new open edges join mesh-border vertices
// (remove_open_border_caps); otherwise the caller simplifies without caps, as before.
// Based on: Garland, Heckbert, "Surface Simplification Using Quadric Error Metrics", SIGGRAPH
// 1997, §6 (boundary preservation by perpendicular constraint planes, here realised as
// triangles so meshopt 0.18 sees them); Karis et al., "Nanite: A Deep Dive", SIGGRAPH 2021,
// §"Locked boundaries" (only the group's shared border needs locking).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "vgeo/dag/build_internal.h"

namespace vgeo::build_detail {

namespace {

// Apex height above the chain's centroid, in units of the chain's bounding-box extent: high
// enough that the cap planes stand steeply on the surface (≥ 45° for every edge of the
// chain's box), so a collapse that moves the border across a hole pays as much as one that
// moves the surface off its plane, and no vertex of the chain is cheap to collapse onto the
// apex itself (it lies an extent away from every face).
constexpr double kCapApexHeightPerExtent = 1.0;

// BorderCaps::origin of an apex.
constexpr uint32_t kApex = ~uint32_t(0);

size_t find_root(std::vector<uint32_t>& parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// SimplifyTarget::keep_loops: which chain edges of one chain (`edges`, corners whose edge runs
// corner -> next corner) get no cap, so that every loop of the chain keeps three vertices
// meshopt cannot move. To meshopt 0.18 a chain vertex is a seam, which collapses only onto a
// neighbouring seam, so a loop with two fixed vertices keeps a third; but a chain that passes
// one welded position twice (a pinch: two sub-mesh vertices there) can shrink between the two
// passes to one vertex, a slit that closes in welded space (a cap base used twice):
// remove_open_border_caps then refuses the whole group's caps, and the group falls back to
// locked borders (elephant-with-holes' two level-1 groups kept 70% of their triangles;
// docs/acceptance/issue23_quality35.md). Fixed are the ends of an uncapped edge (their copies'
// cap edges no longer mirror their open edges: meshopt locks them) and every branch vertex (a
// welded position not on exactly one incoming and one outgoing chain edge: several open edges
// or several vertices at one position, which meshopt locks too; open chains end at one). The
// chain's edges split into maximal paths between branch vertices: a path of two or more edges
// leaves its middle edge uncapped (an inner vertex fixed: a loop through branch vertices then
// holds three), a loop without a branch vertex two edges that share no end (four fixed), one
// of three edges all of them (it stays locked). Fixing more than needed only simplifies less.
std::vector<uint8_t> uncapped_keeping_loops(const std::vector<uint32_t>& edges, const std::vector<unsigned int>& indices,
                                            const std::vector<uint32_t>& welded_of_sub) {
  auto next_corner = [](uint32_t i) { return i - i % 3 + (i + 1) % 3; };
  const uint32_t n = uint32_t(edges.size());
  std::vector<std::pair<uint32_t, uint32_t>> starts, stops;  // (welded vertex, edge)
  for (uint32_t k = 0; k < n; ++k) {
    starts.push_back({welded_of_sub[indices[edges[k]]], k});
    stops.push_back({welded_of_sub[indices[next_corner(edges[k])]], k});
  }
  std::sort(starts.begin(), starts.end());
  std::sort(stops.begin(), stops.end());
  auto first = [](const std::vector<std::pair<uint32_t, uint32_t>>& v, uint32_t x) {
    return std::lower_bound(v.begin(), v.end(), std::pair<uint32_t, uint32_t>{x, 0});
  };
  auto degree = [&](const std::vector<std::pair<uint32_t, uint32_t>>& v, uint32_t x) {
    auto it = first(v, x);
    size_t d = 0;
    while (it != v.end() && it->first == x && d < 2) ++it, ++d;
    return d;
  };
  auto branch = [&](uint32_t x) { return degree(starts, x) != 1 || degree(stops, x) != 1; };
  std::vector<uint8_t> uncapped(n, 0), seen(n, 0);
  std::vector<uint32_t> path;
  // Paths from a branch vertex first, then the loops that have none.
  for (int pure_loops = 0; pure_loops < 2; ++pure_loops) {
    for (uint32_t k0 = 0; k0 < n; ++k0) {
      if (seen[k0] || (!pure_loops && !branch(welded_of_sub[indices[edges[k0]]]))) continue;
      path.clear();
      for (uint32_t k = k0;;) {
        path.push_back(k);
        seen[k] = 1;
        const uint32_t v = welded_of_sub[indices[next_corner(edges[k])]];
        if (branch(v)) break;
        k = first(starts, v)->second;
        if (seen[k]) break;
      }
      if (pure_loops && path.size() <= 3) {
        for (uint32_t k : path) uncapped[k] = 1;
      } else if (pure_loops) {
        uncapped[path[0]] = uncapped[path[path.size() / 2]] = 1;
      } else if (path.size() >= 2) {
        uncapped[path[path.size() / 2]] = 1;
      }
    }
  }
  return uncapped;
}

}  // namespace

OpenBorder find_open_border(const WeldedMesh& welded, const TriangleSet& input, const std::vector<uint8_t>& locked) {
  OpenBorder border;
  EdgeUses uses(input.corners.size());
  for_each_welded_edge(welded, input.corners, [&](uint32_t a, uint32_t b) {
    if (a != b) uses.add(edge_key(a, b));
  });
  for (size_t i = 0; i < input.corners.size(); ++i) {
    const uint32_t a = welded.weld[input.corners[i]], b = welded.weld[input.corners[i - i % 3 + (i + 1) % 3]];
    if (a == b || uses.count(edge_key(a, b)) != 1) continue;
    border.open_edges.push_back(edge_key(a, b));
    if (!(locked[a] && locked[b])) border.chain_corners.push_back(uint32_t(i));
  }
  std::sort(border.open_edges.begin(), border.open_edges.end());
  return border;
}

BorderCaps add_open_border_caps(const std::vector<uint32_t>& chain_corners, const std::vector<uint32_t>& welded_of_sub,
                                const std::vector<uint8_t>& locked, std::vector<unsigned int>& indices,
                                std::vector<float>& positions, bool keep_loops) {
  BorderCaps caps;
  const size_t real_vertices = positions.size() / 3;
  caps.first_apex = real_vertices;
  // chain_corners: corner i's edge (i, next corner) is a chain edge (find_open_border).
  if (chain_corners.empty()) return caps;
  auto next_corner = [](uint32_t i) { return i - i % 3 + (i + 1) % 3; };
  // Chains: connected components of the chain edges over sub-mesh vertices.
  std::vector<uint32_t> parent(real_vertices);
  std::iota(parent.begin(), parent.end(), 0u);
  for (uint32_t i : chain_corners) {
    const size_t ra = find_root(parent, indices[i]), rb = find_root(parent, indices[next_corner(i)]);
    if (ra != rb) parent[std::max(ra, rb)] = uint32_t(std::min(ra, rb));
  }
  // Per chain (by root, in order of first chain corner): its corners.
  std::vector<std::pair<uint32_t, uint32_t>> by_chain;  // (root, corner)
  for (uint32_t i : chain_corners) by_chain.push_back({uint32_t(find_root(parent, indices[i])), i});
  std::stable_sort(by_chain.begin(), by_chain.end(),
                   [](const auto& x, const auto& y) { return x.first < y.first; });
  for (size_t c = 0; c < by_chain.size();) {
    size_t e = c;
    while (e < by_chain.size() && by_chain[e].first == by_chain[c].first) ++e;
    // Centroid, box and area-weighted normal of the chain's edges' triangles.
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double sum[3] = {0, 0, 0}, normal[3] = {0, 0, 0};
    for (size_t k = c; k < e; ++k) {
      const uint32_t i = by_chain[k].second, t = i / 3;
      const float* p = &positions[3 * size_t(indices[i])];
      for (int a = 0; a < 3; ++a) sum[a] += p[a], lo[a] = std::min(lo[a], double(p[a])), hi[a] = std::max(hi[a], double(p[a]));
      const float *p0 = &positions[3 * size_t(indices[3 * t])], *p1 = &positions[3 * size_t(indices[3 * t + 1])],
                  *p2 = &positions[3 * size_t(indices[3 * t + 2])];
      double e1[3], e2[3];
      for (int a = 0; a < 3; ++a) e1[a] = double(p1[a]) - p0[a], e2[a] = double(p2[a]) - p0[a];
      normal[0] += e1[1] * e2[2] - e1[2] * e2[1];
      normal[1] += e1[2] * e2[0] - e1[0] * e2[2];
      normal[2] += e1[0] * e2[1] - e1[1] * e2[0];
    }
    const double len = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    if (!(len > 0) || !(extent > 0)) {  // no direction to stand the cap on: this chain stays locked
      c = e;
      continue;
    }
    const double count = double(e - c), height = kCapApexHeightPerExtent * extent;
    // A closed chain would make the apex interior (free to move): leave out the cap of its
    // first edge, so the apex and that edge's ends stay on the border (locked).
    std::vector<uint32_t> ends;
    for (size_t k = c; k < e; ++k)
      ends.insert(ends.end(), {indices[by_chain[k].second], indices[next_corner(by_chain[k].second)]});
    std::sort(ends.begin(), ends.end());
    bool open_end = false;
    for (size_t k = 0; k < ends.size() && !open_end;) {
      size_t m = k;
      while (m < ends.size() && ends[m] == ends[k]) ++m;
      open_end = (m - k) % 2 == 1;
      k = m;
    }
    // Chain edges left without a cap: with keep_loops, those of uncapped_keeping_loops; a
    // closed chain with none (as without keep_loops) leaves out its first edge's.
    std::vector<uint8_t> uncapped(e - c, 0);
    if (keep_loops) {
      std::vector<uint32_t> edges(e - c);
      for (size_t k = c; k < e; ++k) edges[k - c] = by_chain[k].second;
      uncapped = uncapped_keeping_loops(edges, indices, welded_of_sub);
    }
    if (!open_end && std::find(uncapped.begin(), uncapped.end(), 1) == uncapped.end()) uncapped[0] = 1;
    if (std::find(uncapped.begin(), uncapped.end(), 0) == uncapped.end()) {  // nothing capped: the chain stays locked
      c = e;
      continue;
    }
    const unsigned int apex = unsigned(positions.size() / 3);
    caps.origin.push_back(kApex);
    for (int a = 0; a < 3; ++a) positions.push_back(float(sum[a] / count + normal[a] / len * height));
    // Copies of the chain's vertices (sorted `ends` holds each twice or more): bit-equal for
    // unlocked ones (a seam wedge), a few ulps off for locked ones (their own locked vertex).
    ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
    std::vector<unsigned int> copy_of(ends.size());
    for (size_t k = 0; k < ends.size(); ++k) {
      copy_of[k] = unsigned(positions.size() / 3);
      caps.origin.push_back(ends[k]);
      const float* p = &positions[3 * size_t(ends[k])];
      const float q[3] = {p[0], p[1], p[2]};
      for (int a = 0; a < 3; ++a)
        positions.push_back(locked[welded_of_sub[ends[k]]] ? std::nextafter(q[a], INFINITY) : q[a]);
    }
    auto copy = [&](unsigned int v) {
      return copy_of[std::lower_bound(ends.begin(), ends.end(), v) - ends.begin()];
    };
    for (size_t k = c; k < e; ++k) {
      if (uncapped[k - c]) continue;
      const uint32_t i = by_chain[k].second;
      // The real triangle has a -> b; the cap has b' -> a' (consistent orientation).
      indices.insert(indices.end(), {copy(indices[next_corner(i)]), copy(indices[i]), apex});
      ++caps.cap_triangles;
    }
    ++caps.apex_count;
    c = e;
  }
  return caps;
}

bool remove_open_border_caps(const BorderCaps& caps, const std::vector<uint32_t>& welded_of_sub,
                             const std::vector<uint8_t>& mesh_border, const std::vector<uint64_t>& input_open_edges,
                             std::vector<unsigned int>& out, size_t& out_count) {
  if (caps.apex_count == 0) return true;
  auto appended = [&](unsigned int v) { return v >= caps.first_apex; };
  // Real output triangles are compacted in order; cap triangles give their bases (welded).
  std::vector<uint64_t> bases;
  std::vector<uint8_t> apex_seen(caps.origin.size(), 0);
  EdgeUses real_edges(out_count);  // welded edge uses of the real output
  size_t kept = 0;
  for (size_t t = 0; t < out_count / 3; ++t) {
    const unsigned int* c = &out[3 * t];
    if (appended(c[0]) || appended(c[1]) || appended(c[2])) {
      // A cap triangle: one apex and two copies (a real vertex here is one moved onto the cap).
      int k = 0;
      while (k < 3 && !(appended(c[k]) && caps.origin[c[k] - caps.first_apex] == kApex)) ++k;
      if (k == 3) return false;
      const unsigned int x = c[(k + 1) % 3], y = c[(k + 2) % 3];
      if (!appended(x) || !appended(y)) return false;
      const uint32_t ox = caps.origin[x - caps.first_apex], oy = caps.origin[y - caps.first_apex];
      if (ox == kApex || oy == kApex) return false;
      const uint32_t a = welded_of_sub[ox], b = welded_of_sub[oy];
      // New open edges join mesh-border vertices (spec/dag.md §2.3; verify's crack check).
      if (a == b || !mesh_border[a] || !mesh_border[b]) return false;
      apex_seen[c[k] - caps.first_apex] = 1;
      bases.push_back(edge_key(a, b));
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = welded_of_sub[c[k]], b = welded_of_sub[c[(k + 1) % 3]];
      if (a != b) real_edges.add(edge_key(a, b));
    }
    std::copy_n(c, 3, &out[3 * kept++]);
  }
  // Every apex keeps a cap (else a chain closed over its hole, or the apex moved).
  for (size_t k = 0; k < caps.origin.size(); ++k)
    if (caps.origin[k] == kApex && !apex_seen[k]) return false;
  std::sort(bases.begin(), bases.end());
  // Each cap base is used exactly once by the real output (it is the simplified border there).
  for (size_t i = 0; i < bases.size(); ++i) {
    if (i > 0 && bases[i] == bases[i - 1]) return false;
    if (real_edges.count(bases[i]) != 1) return false;
  }
  // Every open edge of the real output is a cap base or was open in the input (real triangles).
  for (size_t i = 0; i < real_edges.keys.size(); ++i)
    if (real_edges.uses[i] == 1 && !std::binary_search(bases.begin(), bases.end(), real_edges.keys[i]) &&
        !std::binary_search(input_open_edges.begin(), input_open_edges.end(), real_edges.keys[i]))
      return false;
  out_count = 3 * kept;
  return true;
}

}  // namespace vgeo::build_detail
