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

// With every group usable the resident cut is exactly the lod_selects cut.
RC_GTEST_PROP(StreamProperty, AllUsableCutIsTheLodCut, ()) {
  const Fixture& f = fixture();
  const float d = *rc::gen::inRange(0, 4000) / 100.0f;
  const Vec3 eye{d * 0.6f, -d * 0.3f, d};
  const float tau = *rc::gen::element(0.25f, 1.0f, 4.0f);
  for (uint32_t m = 0; m < 2; ++m) {
    const MeshMetadata& mm = f.container.meshes[m];
    LodView v{eye, kPixelsPerUnit, 0.01f};
    const std::vector<uint32_t> cut =
        select_resident_cut(mm.dag, std::vector<uint8_t>(mm.dag.groups.size(), 1), v, tau);
    std::vector<uint32_t> expect;
    for (uint32_t c = 0; c < mm.dag.clusters.size(); ++c) {
      const DagCluster& cl = mm.dag.clusters[c];
      if (lod_selects(cl.lod_bounds, cl.lod_error, cl.parent_bounds, cl.parent_error, v, tau)) expect.push_back(c);
    }
    RC_ASSERT(cut == expect);
  }
}

// Random residency (any subset of pages) gives a valid, crack-free cut.
RC_GTEST_PROP(StreamProperty, AnyResidencyGivesAValidCut, ()) {
  const Fixture& f = fixture();
  const std::vector<uint8_t> pinned = pinned_pages(f.container);
  const uint32_t np = uint32_t(f.container.pages.size());
  const auto resident_bits = *rc::gen::container<std::vector<bool>>(np, rc::gen::arbitrary<bool>());
  const float d = *rc::gen::inRange(0, 3000) / 100.0f;
  for (uint32_t m = 0; m < 2; ++m) {
    const MeshMetadata& mm = f.container.meshes[m];
    std::vector<uint8_t> resident(mm.page_count);
    for (uint32_t k = 0; k < mm.page_count; ++k)
      resident[k] = pinned[mm.first_page + k] || resident_bits[mm.first_page + k];
    const std::vector<uint8_t> usable = usable_groups(mm, resident);
    const std::vector<uint32_t> cut = select_resident_cut(mm.dag, usable, LodView{{0.3f, 0.2f, d}, kPixelsPerUnit, 0.01f}, 1.0f);
    RC_ASSERT(check_cut(f.scene.meshes[m], f.contexts[m], cut).ok());
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
