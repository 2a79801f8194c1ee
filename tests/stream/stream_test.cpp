// Streaming: every frame's cut is valid and crack-free whatever is resident, the pool stays
// within budget, the cut converges once the camera stops, faults never install bad data.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <set>

#include "support/shapes.h"
#include "vgeo/dag/build.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/cull/cull.h"
#include "vgeo/format/format.h"
#include "vgeo/stream/stream.h"
#include "vgeo/verify/verify.h"

namespace vgeo {
namespace {

// 720p, 60° vertical field of view: the default camera's projection.
const float kPixelsPerUnit = lod_projection_scale(1.0471976f, 720.0f);

struct Fixture {
  BuiltScene scene;
  std::vector<CutCheckContext> contexts;
  std::string path;
  FormatContainer container;
  uint64_t total = 0, pinned = 0;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture f;
    BuildOptions bo;
    bo.threads = 1;
    f.scene.meshes.push_back(build_dag(test::make_sphere(48, 96), bo));
    f.scene.meshes.push_back(build_dag(test::make_grid(40, 2.0f, true), bo));
    f.scene.materials.push_back(Material{});
    for (uint32_t m = 0; m < 2; ++m) {
      Instance inst;
      inst.mesh = m;
      f.scene.instances.push_back(inst);
    }
    FormatOptions fo;
    fo.page_size = kMinPageSize;  // many pages and split groups
    fo.zstd_level = 3;
    const std::vector<uint8_t> bytes = encode_format(f.scene, fo);
    f.path = ::testing::TempDir() + "/vgeo_stream_test_" + std::to_string(getpid()) + ".vgp";
    std::ofstream(f.path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    f.container = parse_container(bytes.data(), bytes.size(), "<test>");
    f.total = total_page_bytes(f.container);
    f.pinned = pinned_page_bytes(f.container);
    for (const ClusterDag& d : f.scene.meshes) f.contexts.push_back(prepare_cut_check(d));
    return f;
  }();
  return f;
}

std::vector<StreamView> views_at(Vec3 eye) {
  std::vector<StreamView> v(2);
  for (uint32_t m = 0; m < 2; ++m) {
    v[m].mesh = m;
    v[m].view.eye = eye;
    v[m].view.pixels_per_unit_at_1 = kPixelsPerUnit;
  }
  return v;
}

// Property checked on every frame: each view's cut passes check_cut (coverage + cracks)
// and the pool (resident + in flight) never exceeds the budget.
void expect_frame_ok(const Streamer& s, const StreamFrameStats& st, const std::vector<std::vector<uint32_t>>& cuts,
                     uint64_t budget) {
  const Fixture& f = fixture();
  for (uint32_t m = 0; m < cuts.size(); ++m) {
    const CutCheck check = check_cut(f.scene.meshes[m], f.contexts[m], cuts[m]);
    RC_ASSERT(check.ok());
  }
  if (s.active()) {
    RC_ASSERT(st.reserved_bytes <= budget);
    RC_ASSERT(st.resident_bytes <= budget);
  }
  for (uint32_t p = 0; p < f.container.pages.size(); ++p)
    if (s.page_state(p) == PageState::kResident) RC_ASSERT(!s.page_words(p).empty());
}

TEST(Stream, FixtureHasSeveralPagesAndLevels) {
  const Fixture& f = fixture();
  EXPECT_GT(f.container.pages.size(), 10u);
  EXPECT_GT(f.scene.meshes[0].level_count, 2u);
  EXPECT_LT(f.pinned, f.total / 2);
}

// The renderer's cut (lib/vgeo/cull select_cut, the traversal the frame pipeline runs) of the
// fixture's meshes, each placed at the origin, seen from `eye` looking down -z; `usable`
// null = no streaming. Cluster ids per mesh, ascending.
std::vector<std::vector<uint32_t>> renderer_cut(Vec3 eye, float tau, const std::vector<std::vector<uint8_t>>* usable) {
  const Fixture& f = fixture();
  std::vector<CullInstance> instances(2);
  for (uint32_t m = 0; m < 2; ++m) instances[m].mesh = m;
  ViewParams view;
  view.world_to_view.at(0, 3) = -double(eye.x);
  view.world_to_view.at(1, 3) = -double(eye.y);
  view.world_to_view.at(2, 3) = -double(eye.z);
  view.pixels_per_unit_at_1 = kPixelsPerUnit;
  view.z_near = 0.01;
  ThreadPool pool(2);
  const std::vector<VisibleCluster> cut = select_cut(f.scene.meshes, instances, view, tau, pool, usable);
  return {cut_of_instance(cut, 0), cut_of_instance(cut, 1)};
}

// With every group usable the resident cut is exactly the lod_selects cut: the streamer's
// selection against the flat lod_selects test, and the renderer's resident traversal against
// its own traversal without streaming (same arithmetic, so compared exactly).
RC_GTEST_PROP(StreamProperty, AllUsableCutIsTheLodCut, ()) {
  const Fixture& f = fixture();
  const float d = *rc::gen::inRange(0, 4000) / 100.0f;
  const Vec3 eye{d * 0.6f, -d * 0.3f, d};
  const float tau = *rc::gen::element(0.25f, 1.0f, 4.0f);
  std::vector<std::vector<uint8_t>> all_usable;
  for (uint32_t m = 0; m < 2; ++m) {
    const MeshMetadata& mm = f.container.meshes[m];
    all_usable.push_back(std::vector<uint8_t>(mm.dag.groups.size(), 1));
    LodView v{eye, kPixelsPerUnit, 0.01f};
    const std::vector<uint32_t> cut = select_resident_cut(mm.dag, all_usable.back(), v, tau);
    std::vector<uint32_t> expect;
    for (uint32_t c = 0; c < mm.dag.clusters.size(); ++c) {
      const DagCluster& cl = mm.dag.clusters[c];
      if (lod_selects(cl.lod_bounds, cl.lod_error, cl.parent_bounds, cl.parent_error, v, tau)) expect.push_back(c);
    }
    RC_ASSERT(cut == expect);
    RC_ASSERT(select_resident_cut(mm.dag, {}, v, tau) == expect);
  }
  RC_ASSERT(renderer_cut(eye, tau, &all_usable) == renderer_cut(eye, tau, nullptr));
}

// Random residency (any subset of pages) gives a valid, crack-free cut: the renderer's
// (what a streamed frame draws) and the streamer's selection alike.
RC_GTEST_PROP(StreamProperty, AnyResidencyGivesAValidCut, ()) {
  const Fixture& f = fixture();
  const std::vector<uint8_t> pinned = pinned_pages(f.container);
  const uint32_t np = uint32_t(f.container.pages.size());
  const auto resident_bits = *rc::gen::container<std::vector<bool>>(np, rc::gen::arbitrary<bool>());
  const float d = *rc::gen::inRange(0, 3000) / 100.0f;
  const Vec3 eye{0.3f, 0.2f, d};
  std::vector<std::vector<uint8_t>> usable(2);
  for (uint32_t m = 0; m < 2; ++m) {
    const MeshMetadata& mm = f.container.meshes[m];
    std::vector<uint8_t> resident(mm.page_count);
    for (uint32_t k = 0; k < mm.page_count; ++k)
      resident[k] = pinned[mm.first_page + k] || resident_bits[mm.first_page + k];
    usable[m] = usable_groups(mm, resident);
    const std::vector<uint32_t> cut = select_resident_cut(mm.dag, usable[m], LodView{eye, kPixelsPerUnit, 0.01f}, 1.0f);
    RC_ASSERT(check_cut(f.scene.meshes[m], f.contexts[m], cut).ok());
  }
  const std::vector<std::vector<uint32_t>> drawn = renderer_cut(eye, 1.0f, &usable);
  for (uint32_t m = 0; m < 2; ++m) RC_ASSERT(check_cut(f.scene.meshes[m], f.contexts[m], drawn[m]).ok());
}

// Only the pinned pages resident: the renderer's traversal draws a valid cut from usable groups
// only, coarser than the ideal one, and the streamer's selection (the same resident_lod_test)
// draws the same clusters.
TEST(Stream, RootsOnlyCutIsTheUsableCoarsestLevel) {
  const Fixture& f = fixture();
  const Vec3 eye{0.3f, 0.2f, 2.5f};  // close: the ideal cut is fine, so it differs from the roots
  std::vector<std::vector<uint8_t>> usable(2);
  for (uint32_t m = 0; m < 2; ++m) {
    const MeshMetadata& mm = f.container.meshes[m];
    std::vector<uint8_t> resident(mm.page_count);
    const std::vector<uint8_t> pinned = pinned_pages(f.container);
    for (uint32_t k = 0; k < mm.page_count; ++k) resident[k] = pinned[mm.first_page + k];
    usable[m] = usable_groups(mm, resident);
  }
  const std::vector<std::vector<uint32_t>> drawn = renderer_cut(eye, 1.0f, &usable);
  const std::vector<std::vector<uint32_t>> ideal = renderer_cut(eye, 1.0f, nullptr);
  for (uint32_t m = 0; m < 2; ++m) {
    const ClusterDag& dag = f.scene.meshes[m];
    EXPECT_TRUE(check_cut(dag, f.contexts[m], drawn[m]).ok()) << "mesh " << m;
    // The sphere's ideal cut is finer than its roots here (the flat grid simplifies without
    // error, so its ideal cut is its roots already).
    if (m == 0) {
      EXPECT_NE(drawn[m], ideal[m]);
    }
    ASSERT_FALSE(drawn[m].empty());
    for (uint32_t c : drawn[m]) EXPECT_TRUE(usable[m][dag.clusters[c].group]) << "cluster " << c;
    EXPECT_EQ(drawn[m], select_resident_cut(f.container.meshes[m].dag, usable[m],
                                            LodView{eye, kPixelsPerUnit, 0.01f}, 1.0f)) << "mesh " << m;
  }
}

// The main property: random budgets (roots only .. everything), random camera paths; every
// frame valid and within budget; after the camera stops, the cut becomes the fully-resident
// cut within a bounded number of frames whenever the budget covers what it needs.
RC_GTEST_PROP(StreamProperty, FramesValidWithinBudgetAndConverge, ()) {
  const Fixture& f = fixture();
  const uint64_t budget = f.pinned + uint64_t(*rc::gen::inRange(0, 1001)) * (f.total - f.pinned) / 1000;
  StreamOptions o;
  o.budget_bytes = budget;
  o.loader.asynchronous = false;
  o.max_issues_per_frame = *rc::gen::inRange(1u, 9u);
  Streamer s(f.path, o);
  RC_ASSERT(s.active() == (budget < f.total));
  const uint32_t moving = *rc::gen::inRange(1u, 8u);
  std::vector<std::vector<uint32_t>> cuts;
  Vec3 eye{};
  for (uint32_t i = 0; i < moving; ++i) {
    const float d = *rc::gen::inRange(0, 3000) / 100.0f;
    const float a = *rc::gen::inRange(0, 628) / 100.0f;
    eye = {d * std::cos(a), d * std::sin(a), 0.5f + d * 0.2f};
    const StreamFrameStats st = s.update(views_at(eye), &cuts);
    expect_frame_ok(s, st, cuts, budget);
  }
  // Camera stopped.
  const uint32_t np = uint32_t(f.container.pages.size());
  const uint32_t bound = np / o.max_issues_per_frame + 3;
  bool fits = false;
  uint32_t converged_at = kNone;
  for (uint32_t i = 0; i < bound + 2; ++i) {
    const StreamFrameStats st = s.update(views_at(eye), &cuts);
    expect_frame_ok(s, st, cuts, budget);
    fits = st.required_bytes <= budget;
    if (st.cut_is_ideal && converged_at == kNone) converged_at = i;
    if (converged_at != kNone) RC_ASSERT(st.cut_is_ideal);  // stays converged
  }
  if (fits) RC_ASSERT(converged_at <= bound);
  RC_TAG(fits ? "fits" : "over budget");
}

// Eviction never removes a page that a resident child group depends on.
RC_GTEST_PROP(StreamProperty, EvictionKeepsParentsOfResidentChildren, ()) {
  const Fixture& f = fixture();
  StreamOptions o;
  o.budget_bytes = f.pinned + uint64_t(*rc::gen::inRange(100, 900)) * (f.total - f.pinned) / 1000;
  o.loader.asynchronous = false;
  Streamer s(f.path, o);
  const uint32_t np = uint32_t(f.container.pages.size());
  uint64_t evictions = 0;
  for (uint32_t i = 0; i < 30; ++i) {
    std::vector<PageState> before(np);
    for (uint32_t p = 0; p < np; ++p) before[p] = s.page_state(p);
    // Close-ups and far views from random sides need different pages: the pool churns.
    const float d = 1.1f + *rc::gen::inRange(0, 1000) / 100.0f;
    const float a = *rc::gen::inRange(0, 628) / 100.0f;
    const StreamFrameStats st = s.update(views_at({d * std::cos(a), d * std::sin(a), 0.3f}), nullptr);
    evictions += st.pages_evicted;
    for (uint32_t p = 0; p < np; ++p) {
      if (before[p] != PageState::kResident || s.page_state(p) != PageState::kAbsent) continue;
      RC_ASSERT(!s.page_pinned(p));
      for (uint32_t q = 0; q < np; ++q)
        if (s.page_state(q) == PageState::kResident)
          for (uint32_t parent : s.page_parents(q)) RC_ASSERT(parent != p);
    }
  }
  RC_TAG(evictions > 0 ? "evicted" : "no eviction");
}

// The victim choice itself (deterministic, no streaming run): a page a resident child group
// depends on is never evicted, whatever the page order. Here the child page 0 comes before its
// parent page 1, so the key alone (equal keys: higher page index first) would pick the parent.
TEST(StreamEviction, VictimIsNeverAPageWithAResidentChild) {
  std::vector<PageState> state(3, PageState::kResident);
  const std::vector<uint8_t> pinned{0, 0, 1};
  // page 1 holds page 0's parent group; page 2 (pinned, the root) holds page 1's.
  const std::vector<std::vector<uint32_t>> children{{}, {0}, {1}};
  std::vector<uint64_t> last_wanted{5, 5, 5};
  std::vector<float> priority{1, 1, 1};
  const EvictionView v{state, pinned, children, last_wanted, priority, 9};
  EXPECT_TRUE(page_evictable(v, 0));
  EXPECT_FALSE(page_evictable(v, 1)) << "resident child page 0 depends on it";
  EXPECT_FALSE(page_evictable(v, 2)) << "pinned";
  EXPECT_EQ(choose_eviction_victim(v), 0u);
  last_wanted = {7, 3, 3};  // the parent is the least recently wanted: still not evictable
  priority = {2, 0.5f, 0.5f};
  EXPECT_EQ(choose_eviction_victim(v), 0u);
  state[0] = PageState::kAbsent;  // the child is gone: now the parent may go
  EXPECT_EQ(choose_eviction_victim(v), 1u);
  state[1] = PageState::kInFlight;  // nothing installed but the pinned root
  EXPECT_EQ(choose_eviction_victim(v), kNone);
}

// The victim key: pages not wanted this frame before wanted ones (least recently wanted
// first), then lower priority, then the higher page index (finer data).
TEST(StreamEviction, VictimKeyOrder) {
  const std::vector<PageState> state(4, PageState::kResident);
  const std::vector<uint8_t> pinned(4, 0);
  const std::vector<std::vector<uint32_t>> children(4);
  std::vector<uint64_t> last_wanted{9, 9, 4, 6};
  std::vector<float> priority{0.1f, 3, 5, 1};
  const EvictionView v{state, pinned, children, last_wanted, priority, 9};
  EXPECT_EQ(choose_eviction_victim(v), 2u);  // not wanted, least recently
  last_wanted = {9, 9, 9, 9};
  EXPECT_EQ(choose_eviction_victim(v), 0u);  // all wanted: lowest priority
  priority = {1, 1, 1, 1};
  EXPECT_EQ(choose_eviction_victim(v), 3u);  // ties: the higher page index
}

// The requests of `mesh`'s ideal cut seen from `eye` (what a view's traversal emits), each with
// its projected parent error, or that mapped by secondary_view_priority (a shadow view).
std::vector<GroupRequest> ideal_requests(uint32_t mesh, Vec3 eye, bool shadow_view, float tau) {
  const Fixture& f = fixture();
  const ClusterDag& dag = f.container.meshes[mesh].dag;
  const StreamView v = views_at(eye)[mesh];
  std::vector<GroupRequest> out;
  for (uint32_t c : select_resident_cut(dag, {}, v.view, tau)) {
    const float p = projected_error(dag.clusters[c].parent_bounds, dag.clusters[c].parent_error, v.view);
    out.push_back({mesh, dag.clusters[c].group, shadow_view ? secondary_view_priority(p, tau) : p});
  }
  return out;
}

// Per page: the mesh whose groups it holds (the fixture's pages hold one mesh each).
std::vector<uint32_t> page_meshes() {
  const Fixture& f = fixture();
  std::vector<uint32_t> out(f.container.pages.size(), kNone);
  for (uint32_t m = 0; m < f.container.meshes.size(); ++m) {
    const MeshMetadata& mm = f.container.meshes[m];
    for (uint32_t g = 0; g < mm.group_first_page.size(); ++g)
      for (uint32_t p = mm.group_first_page[g]; mm.group_first_page[g] != kNone && p < mm.group_first_page[g] + mm.group_page_count[g]; ++p) {
        EXPECT_TRUE(out[p] == kNone || out[p] == m);
        out[p] = m;
      }
  }
  return out;
}

// spec/stream.md §Requests: a lower-priority view's requests (shadow views) are served only
// after the primary view's. The primary view wants the sphere (mesh 0), a shadow view the grid
// (mesh 1) from nearer, so its own projected errors exceed the primary's. With the budget
// between what the primary view needs (plus one grid page) and everything: no grid page is issued while a page the
// primary view needs is missing, the primary view's pages all become resident, and grid pages
// take only the rest. With the shadow view's raw errors as priorities (no mapping) the grid's
// pages would go first: the same check fails there.
TEST(Stream, PrimaryRequestsAreServedBeforeShadowRequests) {
  const Fixture& f = fixture();
  const float tau = 1.0f;
  const std::vector<uint32_t> mesh_of = page_meshes();
  const std::vector<GroupRequest> primary = ideal_requests(0, {0, 0, 4.0f}, false, tau);
  // secondary_view_priority inverted: the shadow view's own projected error.
  auto raw = [&](float mapped) {
    const double q = double(mapped) / tau;
    return float(q / (1 - q));
  };
  // What the primary view alone loads (its needs and their parents), and its bytes.
  StreamOptions o;
  o.budget_bytes = f.total - 1;
  o.loader.asynchronous = false;
  o.max_issues_per_frame = 2;
  std::vector<uint8_t> primary_pages(mesh_of.size(), 0);
  uint64_t primary_bytes = 0;
  {
    Streamer s(f.path, o);
    for (uint32_t frame = 0; frame < 2 * f.container.pages.size(); ++frame) {
      StreamFrameStats st = s.begin_frame();
      s.end_frame(primary, &st);
    }
    for (uint32_t p = 0; p < mesh_of.size(); ++p)
      if (s.page_state(p) == PageState::kResident && !s.page_pinned(p)) {
        primary_pages[p] = 1;
        primary_bytes += f.container.pages[p].memory_size;
      }
  }
  ASSERT_GT(primary_bytes, 0u);
  const std::vector<GroupRequest> shadow = ideal_requests(1, {1.0f, 0.4f, 0.15f}, true, tau);
  float primary_max = 0, shadow_raw_max = 0;
  for (const GroupRequest& r : primary) primary_max = std::max(primary_max, r.priority);
  for (const GroupRequest& r : shadow) shadow_raw_max = std::max(shadow_raw_max, raw(r.priority));
  ASSERT_GT(shadow_raw_max, primary_max);  // unmapped, the shadow view would outrank the primary one
  // Room for the primary view's pages and any one grid page (whichever the shadow view asks for
  // first), and less than everything: the budget must choose.
  uint64_t largest_grid_page = 0;
  for (uint32_t p = 0; p < mesh_of.size(); ++p)
    if (mesh_of[p] == 1 && !primary_pages[p]) largest_grid_page = std::max<uint64_t>(largest_grid_page, f.container.pages[p].memory_size);
  const uint64_t budget = f.pinned + primary_bytes + largest_grid_page;
  ASSERT_LT(budget, f.total);
  for (bool mapped : {true, false}) {
    StreamOptions ob = o;
    ob.budget_bytes = budget;
    Streamer s(f.path, ob);
    std::vector<GroupRequest> requests = primary;
    for (GroupRequest r : shadow) {
      if (!mapped) r.priority = raw(r.priority);
      requests.push_back(r);
    }
    uint32_t grid_before_primary = 0, grid_loaded = 0;
    for (uint32_t frame = 0; frame < 2 * f.container.pages.size(); ++frame) {
      StreamFrameStats st = s.begin_frame();
      s.end_frame(requests, &st);
      bool grid_in_flight = false, primary_missing = false;
      for (uint32_t p = 0; p < mesh_of.size(); ++p) {
        grid_in_flight |= mesh_of[p] == 1 && s.page_state(p) == PageState::kInFlight;
        primary_missing |= primary_pages[p] && s.page_state(p) == PageState::kAbsent;
      }
      grid_before_primary += grid_in_flight && primary_missing;
    }
    bool primary_resident = true;
    for (uint32_t p = 0; p < mesh_of.size(); ++p) {
      primary_resident &= !primary_pages[p] || s.page_state(p) == PageState::kResident;
      grid_loaded += mesh_of[p] == 1 && !s.page_pinned(p) && s.page_state(p) == PageState::kResident;
    }
    if (mapped) {
      EXPECT_EQ(grid_before_primary, 0u);
      EXPECT_TRUE(primary_resident);
      EXPECT_GT(grid_loaded, 0u);  // the rest of the budget serves the shadow view
    } else {
      EXPECT_GT(grid_before_primary, 0u);
    }
  }
}

TEST(Stream, InactiveWhenEverythingFits) {
  const Fixture& f = fixture();
  StreamOptions o;
  o.budget_bytes = f.total;
  Streamer s(f.path, o);
  EXPECT_FALSE(s.active());
  std::vector<std::vector<uint32_t>> cuts;
  const StreamFrameStats st = s.update(views_at({0, 0, 3}), &cuts);
  EXPECT_FALSE(st.active);
  EXPECT_TRUE(st.cut_is_ideal);
  EXPECT_EQ(st.pages_issued, 0u);
  EXPECT_EQ(s.resident_bytes(), f.total);
}

TEST(Stream, BudgetBelowPinnedPagesIsRejected) {
  const Fixture& f = fixture();
  StreamOptions o;
  o.budget_bytes = f.pinned - 1;
  try {
    Streamer s(f.path, o);
    FAIL() << "accepted a budget below the pinned pages";
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, kErrStreamBudget);
  }
}

TEST(Stream, MissingFileIsAnIoError) {
  StreamOptions o;
  try {
    Streamer s("/nonexistent/vgeo.vgp", o);
    FAIL();
  } catch (const VgeoError& e) {
    EXPECT_EQ(e.error().code, kErrFileNotFound);
    EXPECT_EQ(e.error().exit_code, kExitIo);
  }
}

// ---- faults ----

struct FaultRun {
  StreamTotals totals;
  bool all_frames_valid = true;
  bool converged = false;
  PageState faulty_state = PageState::kAbsent;
};

// Streams a close-up view of the sphere (needs leaf pages) with `fault` injected on one
// requested non-pinned page.
FaultRun run_with_fault(PageFault kind, uint32_t failing_attempts, bool asynchronous) {
  const Fixture& f = fixture();
  const Vec3 eye{0, 0, 1.3f};
  // Pick a page the view needs: run a clean streamer to convergence first.
  uint32_t target = kNone;
  {
    StreamOptions o;
    o.budget_bytes = f.total - 1;
    o.loader.asynchronous = false;
    Streamer clean(f.path, o);
    for (int i = 0; i < 40; ++i) clean.update(views_at(eye), nullptr);
    for (uint32_t p = uint32_t(f.container.pages.size()); p-- > 0;)
      if (clean.page_state(p) == PageState::kResident && !clean.page_pinned(p) && f.container.pages[p].mesh == 0) {
        target = p;
        break;
      }
  }
  EXPECT_NE(target, kNone);
  StreamOptions o;
  o.budget_bytes = f.total - 1;
  o.loader.asynchronous = asynchronous;
  o.loader.slow_read_extra_ms = 5;
  o.loader.fault = [=](uint32_t page, uint32_t attempt) {
    return page == target && attempt < failing_attempts ? kind : PageFault::kNone;
  };
  Streamer s(f.path, o);
  FaultRun r;
  std::vector<std::vector<uint32_t>> cuts;
  for (int i = 0; i < 60; ++i) {
    const StreamFrameStats st = s.update(views_at(eye), &cuts);
    for (uint32_t m = 0; m < 2; ++m)
      r.all_frames_valid = r.all_frames_valid && check_cut(f.scene.meshes[m], f.contexts[m], cuts[m]).ok();
    r.converged = st.cut_is_ideal;
    if (asynchronous) s.wait_idle();
  }
  r.totals = s.totals();
  r.faulty_state = s.page_state(target);
  return r;
}

TEST(StreamFaults, PermanentIoErrorMarksPageBad) {
  const FaultRun r = run_with_fault(PageFault::kIoError, 1000, false);
  EXPECT_TRUE(r.all_frames_valid);
  EXPECT_EQ(r.faulty_state, PageState::kBad);
  EXPECT_EQ(r.totals.read_failures, StreamOptions{}.max_attempts);
  EXPECT_EQ(r.totals.pages_marked_bad, 1u);
  EXPECT_FALSE(r.converged);  // drawn coarser where the bad page's groups would be
}

TEST(StreamFaults, PermanentShortReadMarksPageBad) {
  const FaultRun r = run_with_fault(PageFault::kShortRead, 1000, false);
  EXPECT_TRUE(r.all_frames_valid);
  EXPECT_EQ(r.faulty_state, PageState::kBad);
  EXPECT_EQ(r.totals.read_failures, StreamOptions{}.max_attempts);
}

TEST(StreamFaults, CorruptPageIsNeverInstalled) {
  const FaultRun r = run_with_fault(PageFault::kCorrupt, 1000, false);
  EXPECT_TRUE(r.all_frames_valid);
  EXPECT_EQ(r.faulty_state, PageState::kBad);
  EXPECT_EQ(r.totals.checksum_failures, StreamOptions{}.max_attempts);
}

TEST(StreamFaults, TransientFaultsAreRetriedAndConverge) {
  for (PageFault kind : {PageFault::kIoError, PageFault::kShortRead, PageFault::kCorrupt}) {
    const FaultRun r = run_with_fault(kind, 2, false);
    EXPECT_TRUE(r.all_frames_valid);
    EXPECT_EQ(r.faulty_state, PageState::kResident);
    EXPECT_EQ(r.totals.read_failures + r.totals.checksum_failures, 2u);
    EXPECT_EQ(r.totals.pages_marked_bad, 0u);
    EXPECT_TRUE(r.converged);
  }
}

TEST(StreamFaults, SlowReadsOnTheWorkerThreadConverge) {
  const FaultRun r = run_with_fault(PageFault::kSlow, 1000, true);
  EXPECT_TRUE(r.all_frames_valid);
  EXPECT_EQ(r.faulty_state, PageState::kResident);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.totals.read_failures, 0u);
}

TEST(StreamFaults, AsynchronousFaultsStayValid) {
  const FaultRun r = run_with_fault(PageFault::kCorrupt, 1000, true);
  EXPECT_TRUE(r.all_frames_valid);
  EXPECT_EQ(r.faulty_state, PageState::kBad);
}

}  // namespace
}  // namespace vgeo
