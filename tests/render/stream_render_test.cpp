// Streaming through the real renderer (spec/stream.md §Renderer): every frame's resident cut
// passes lib/vgeo/verify's cut check (coverage + cracks), drawn clusters are a subset of it and
// their geometry is exactly the page file's, the pool stays within budget, the cut converges
// after the camera stops, faults never produce an invalid cut, and without need there is no
// streaming at all (bit-identical output).
#include <gtest/gtest.h>

#include <chrono>

#include <cstring>
#include <map>
#include <random>

#include "render/stream_fixture.h"
#include "vgeo/core/error.h"

namespace vgeo {
namespace {

using test::stream_fixture;

// The deterministic loader (each read completes at the next frame) unless `stream` says otherwise.
StreamOptions sync_stream() {
  StreamOptions so;
  so.loader.asynchronous = false;
  return so;
}

SceneFile load(const std::string& json, std::optional<uint64_t> budget, StreamOptions stream = sync_stream()) {
  SceneLoadOptions o;
  if (budget) {
    stream.budget_bytes = *budget;
    o.stream = stream;
  }
  return parse_scene_json(json, "<test>", "", o);
}

struct FrameChecker {
  const SceneFile* file = nullptr;
  uint64_t budget = 0;
  float tau = 1;
  ThreadPool pool{2};
  uint32_t frames_checked = 0;
  void operator()(uint32_t, const Frame& frame, const FrameStreaming* s) {
    const test::StreamFixture& f = stream_fixture();
    ASSERT_NE(s, nullptr);
    // The resident cut the traversal used (LOD only: whole instances) is valid and crack-free.
    const std::vector<VisibleCluster> cut =
        select_cut(file->scene.meshes, file->scene.instances, frame.view, tau, pool, &s->usable);
    for (uint32_t i = 0; i < file->scene.instances.size(); ++i) {
      const uint32_t m = file->scene.instances[i].mesh;
      const CutCheck check = check_cut(f.built.meshes[m], f.contexts[m], cut_of_instance(cut, i));
      ASSERT_TRUE(check.ok()) << "instance " << i << " frame " << frame.stats.stream.frame;
    }
    // Drawn ⊆ cut; each drawn cluster's geometry is the page file's.
    for (const VisibleCluster& v : frame.visible) {
      ASSERT_TRUE(std::binary_search(cut.begin(), cut.end(), v));
      const uint32_t m = file->scene.instances[v.instance].mesh;
      const ClusterDag& want = f.decoded.meshes[m];
      const ClusterDag& got = s->geometry[m];
      const DagCluster &cw = want.clusters[v.cluster], &cg = got.clusters[v.cluster];
      ASSERT_EQ(cw.vertex_count, cg.vertex_count);
      ASSERT_EQ(0, std::memcmp(want.positions.data() + 3 * size_t(cw.vertex_offset),
                               got.positions.data() + 3 * size_t(cg.vertex_offset), 12 * size_t(cw.vertex_count)));
      ASSERT_EQ(0, std::memcmp(want.indices.data() + 3 * size_t(cw.triangle_offset),
                               got.indices.data() + 3 * size_t(cg.triangle_offset), 3 * size_t(cw.triangle_count)));
    }
    ASSERT_TRUE(frame.stats.streamed);
    ASSERT_LE(frame.stats.stream.reserved_bytes, budget);
    ASSERT_LE(frame.stats.stream.resident_bytes, budget);
    ++frames_checked;
  }
};

TEST(StreamRender, FixtureNeedsStreaming) {
  const test::StreamFixture& f = stream_fixture();
  EXPECT_GT(f.pages, 12u);
  EXPECT_LT(f.pinned, f.total / 3);
}

// Streaming is decided once, at load, from the one budget (SceneLoadOptions::stream), and the
// render follows it; each page file's metadata is read once, at load, and handed to the Streamer.
TEST(StreamRender, LoadDecidesStreamingAndTheRenderFollowsIt) {
  const test::StreamFixture& f = stream_fixture();
  const std::string json = test::stream_scene_json(f.path, 3, 10, 3, true);
  for (const uint64_t budget : {f.total - 1, f.total}) {
    const SceneFile file = load(json, budget);
    const bool on = budget < f.total;  // both meshes of the one file are used
    EXPECT_EQ(file.streaming, on) << budget;
    EXPECT_EQ(file.page_files.size(), on ? 1u : 0u);  // two scene meshes, one file: read once
    if (on) {
      EXPECT_EQ(file.page_files[0].metadata.pages.size(), f.pages);
    }
    RenderRequest req;
    req.threads = 2;
    req.frames = 2;
    const RenderReport r = render_scene(file, req);
    EXPECT_EQ(r.stream.active, on);
    EXPECT_EQ(r.stream.note, file.stream_note());
    EXPECT_EQ(r.stream.budget_bytes, budget);
    for (const FrameStats& s : r.frames) {
      EXPECT_EQ(s.streamed, on);
      std::string reason;
      for (const auto& [name, why] : s.skipped)
        if (name == "stream") reason = why;
      EXPECT_EQ(reason, on ? "" : file.stream_reason);
    }
  }
}

// Property over seeded random cases: scenes of 1-4 instances, camera paths far→near, budgets
// from roots only to everything but one byte, τ, occlusion on/off.
TEST(StreamRender, EveryFrameCutValidWithinBudgetAndConverges) {
  const test::StreamFixture& f = stream_fixture();
  std::mt19937 rng(6);
  constexpr int kCases = 16;
  uint32_t converged_cases = 0, evicting_cases = 0;
  for (int k = 0; k < kCases; ++k) {
    uint32_t instances = 1 + rng() % 5;
    bool occlusion = rng() % 2;
    double far = 6 + rng() % 30, near_ = 1.2 + (rng() % 10) * 0.3;
    // Extremes are common: roots only, everything but one byte.
    const uint64_t span = f.total - 1 - f.pinned;
    uint64_t budget = k == 0 ? f.pinned : k == 1 ? f.total - 1 : f.pinned + rng() % span;
    // Case 2 is the fly-through of tests/gpu's streamed scenes (3 instances, 12 → 2, a quarter
    // of the streamed bytes), which evicts, so the evicting regime is reached whatever the
    // fixture DAG's page layout (the random cases missed it once lone groups changed the grid's
    // DAG). The random draws above are still made: the other cases stay as they were.
    if (k == 2) instances = 3, occlusion = true, far = 12, near_ = 2, budget = f.pinned + (f.total - f.pinned) / 4;
    SceneFile file = load(test::stream_scene_json(f.path, instances, far, near_, occlusion), budget);
    ASSERT_TRUE(file.streaming);
    RenderRequest req;
    req.threads = 2;
    req.threshold_px = k % 3 == 0 ? 0.5f : k % 3 == 1 ? 1.0f : 4.0f;
    const uint32_t settle = f.pages / file.stream->max_issues_per_frame + 4;
    req.frames = uint32_t(file.path.size()) + settle;
    FrameChecker check;
    check.file = &file;
    check.budget = budget;
    check.tau = *req.threshold_px;
    RenderReport r = render_scene(file, req, std::ref(check));
    ASSERT_FALSE(::testing::Test::HasFatalFailure()) << "case " << k;
    ASSERT_EQ(check.frames_checked, req.frames);
    const StreamFrameStats& last = r.frames.back().stream;
    // The summary splits reads at the stop: frames ≥ stop_frame hold the final camera.
    uint64_t after_stop = 0;
    for (uint32_t fr = r.stream.stop_frame; fr < r.frames.size(); ++fr) after_stop += r.frames[fr].stream.bytes_read;
    EXPECT_EQ(r.stream.stop_frame, file.path.size() - 1);
    EXPECT_EQ(r.stream.bytes_read_after_stop, after_stop);
    EXPECT_LE(r.stream.pages_loaded_after_stop, r.stream.pages_loaded);
    EXPECT_EQ(r.stream.stop_required_bytes, last.required_bytes);
    // Convergence (occlusion off: requests depend only on the stopped camera).
    if (!occlusion && last.required_bytes <= budget) {
      EXPECT_TRUE(last.cut_is_ideal) << "case " << k;
      EXPECT_GE(r.stream.frames_to_converge, 0) << "case " << k;
      EXPECT_LE(r.stream.frames_to_converge, int64_t(settle)) << "case " << k;
      converged_cases++;
    }
    evicting_cases += r.stream.pages_evicted > 0;
    if (k == 0) {
      EXPECT_EQ(r.stream.pages_loaded, 0u);  // roots only: nothing else fits
    }
  }
  // The generator reaches both regimes.
  EXPECT_GT(converged_cases, 0u);
  EXPECT_GT(evicting_cases, 0u);
}

// Once converged, the streamed frame is the unstreamed frame: same visibility buffer.
TEST(StreamRender, ConvergedFrameEqualsTheUnstreamedFrame) {
  const test::StreamFixture& f = stream_fixture();
  const std::string json = test::stream_scene_json(f.path, 3, 20, 8, false);
  SceneFile streamed = load(json, f.total - 1);
  SceneFile plain = load(json, std::nullopt);
  ASSERT_TRUE(streamed.streaming);
  RenderRequest req;
  req.threads = 2;
  req.frames = 30;
  RenderReport a = render_scene(streamed, req);
  ASSERT_TRUE(a.frames.back().stream.cut_is_ideal);
  RenderReport b = render_scene(plain, req);
  EXPECT_EQ(a.vis_hash, b.vis_hash);
  EXPECT_EQ(a.image_hash, b.image_hash);
  // Pacing changes wall time only (synchronous loader: the same frames, the same reads).
  RenderRequest paced = req;
  paced.frames = 6;
  paced.frame_interval_ms = 2;
  RenderRequest unpaced = paced;
  unpaced.frame_interval_ms = 0;
  const auto start = std::chrono::steady_clock::now();
  RenderReport p = render_scene(streamed, paced);
  const auto paced_wall = std::chrono::steady_clock::now() - start;
  RenderReport u = render_scene(streamed, unpaced);
  EXPECT_EQ(p.image_hash, u.image_hash);
  EXPECT_EQ(p.vis_hash, u.vis_hash);
  EXPECT_EQ(p.stream.bytes_read, u.stream.bytes_read);
  EXPECT_GE(paced_wall, std::chrono::milliseconds(10));  // 5 paced intervals of 2 ms (not after the last frame)
}

// spec/shadow.md §9: a lit scene renders with streaming: every frame runs the shadow steps (the
// shadow views draw the resident cut, request theirs at lower priority), every frame's cut stays
// valid within the budget, and once converged (the primary cut ideal, no provisional shadow page
// left) the image equals the unstreamed one. A spot light: its map does not move with the
// camera, so a page's depths do not depend on the frame that drew it.
TEST(StreamRender, LitSceneRendersWithShadowsAndConvergesToTheUnstreamedImage) {
  const test::StreamFixture& f = stream_fixture();
  std::string json = test::stream_scene_json(f.path, 3, 20, 8, false);
  json.insert(json.rfind('}'), ",\"lights\":[{\"type\":\"spot\",\"position\":[3,6,2],\"direction\":[-0.4,-1,-0.5],"
                               "\"cone_degrees\":100}]");
  SceneFile streamed = load(json, f.total - 1);
  SceneFile plain = load(json, std::nullopt);
  ASSERT_TRUE(streamed.streaming);
  ASSERT_EQ(streamed.scene.lights.size(), 1u);
  FrameChecker check;
  check.file = &streamed;
  check.budget = f.total - 1;
  RenderRequest req;
  req.threads = 2;
  req.frames = 30;
  RenderReport a = render_scene(streamed, req, std::ref(check));
  EXPECT_EQ(check.frames_checked, 30u);
  for (const FrameStats& s : a.frames) {
    EXPECT_TRUE(s.has_shadow);
    EXPECT_GT(s.shadow.pages_marked, 0u);
  }
  ASSERT_TRUE(a.frames.back().stream.cut_is_ideal);
  EXPECT_EQ(a.frames.back().shadow.pages_drawn, 0u);  // converged: every page cached (none provisional)
  RenderReport b = render_scene(plain, req);
  EXPECT_EQ(a.vis_hash, b.vis_hash);
  EXPECT_EQ(a.image_hash, b.image_hash);
}

// A static camera: the first frames find only the pinned pages resident, so their shadow pages
// are drawn from a coarser cut (provisional) and must not stay cached: later frames redraw them
// as the data arrives, and the converged image equals the unstreamed one.
TEST(StreamRender, ProvisionalShadowPagesAreRedrawnWhenTheirDataArrives) {
  const test::StreamFixture& f = stream_fixture();
  std::string json = test::stream_scene_json(f.path, 3, 2.2, 2.2, false);
  const size_t path = json.find(",\"camera_path\""), settings = json.find(",\"settings\"");
  ASSERT_NE(path, std::string::npos);
  json.erase(path, settings - path);  // the scene camera, held for every frame
  const size_t res = json.find("[96,72]");
  ASSERT_NE(res, std::string::npos);
  json.replace(res, 7, "[320,240]");  // fine enough that the shadow views want more than the pinned pages
  json.insert(json.rfind('}'), ",\"lights\":[{\"type\":\"spot\",\"position\":[3,6,2],\"direction\":[-0.4,-1,-0.5],"
                               "\"cone_degrees\":100}]");
  SceneFile streamed = load(json, f.total - 1);
  SceneFile plain = load(json, std::nullopt);
  ASSERT_TRUE(streamed.streaming);
  RenderRequest req;
  req.threads = 2;
  req.frames = 30;
  // The last frame's shadow pages (page-table entry → texels), to compare with the unstreamed run.
  auto last_pages = [&](std::map<size_t, std::vector<float>>* out) {
    return [out, frames = req.frames](uint32_t k, const Frame& frame, const FrameStreaming*) {
      if (k + 1 != frames) return;
      const size_t n = size_t(kShadowPageTexels) * kShadowPageTexels;
      const std::vector<float>& texels = frame.shadow.pool_texels ? *frame.shadow.pool_texels : frame.shadow.own_texels;
      for (size_t e = 0; e < frame.shadow.needed.size(); ++e)
        if (frame.shadow.needed[e] && frame.shadow.page_table[e] != kNoShadowSlot) {
          const float* t = texels.data() + size_t(frame.shadow.page_table[e]) * n;
          (*out)[e] = std::vector<float>(t, t + n);
        }
    };
  };
  std::map<size_t, std::vector<float>> streamed_pages, plain_pages;
  RenderReport a = render_scene(streamed, req, last_pages(&streamed_pages));
  uint64_t redrawn = 0;  // pages drawn after the first frame: only provisional ones (camera and light hold)
  for (size_t k = 1; k < a.frames.size(); ++k) redrawn += a.frames[k].shadow.pages_drawn;
  EXPECT_GT(redrawn, 0u);
  ASSERT_TRUE(a.frames.back().stream.cut_is_ideal);
  EXPECT_EQ(a.frames.back().shadow.pages_drawn, 0u);
  RenderReport b = render_scene(plain, req, last_pages(&plain_pages));
  EXPECT_EQ(a.image_hash, b.image_hash);
  EXPECT_FALSE(plain_pages.empty());
  EXPECT_TRUE(streamed_pages == plain_pages);  // the same pages, texel for texel
}

// No budget, or data within it: the stream pass is absent and output is bit-identical.
TEST(StreamRender, DataWithinBudgetMeansNoStreamPass) {
  const test::StreamFixture& f = stream_fixture();
  const std::string json = test::stream_scene_json(f.path, 2, 10, 3, true);
  SceneFile fits = load(json, f.total);
  SceneFile plain = load(json, std::nullopt);
  EXPECT_FALSE(fits.streaming);
  EXPECT_EQ(fits.page_bytes, f.total);
  RenderRequest req;
  req.threads = 2;
  RenderReport a = render_scene(fits, req);
  RenderReport b = render_scene(plain, req);
  EXPECT_EQ(a.vis_hash, b.vis_hash);
  EXPECT_EQ(a.image_hash, b.image_hash);
  for (const FrameStats& s : a.frames) {
    EXPECT_FALSE(s.streamed);
    EXPECT_EQ(s.find("stream"), nullptr);
  }
  EXPECT_NE(a.stream.note.find("streaming: off"), std::string::npos);
  EXPECT_TRUE(b.stream.note.empty());
}

// Each fault kind under the renderer: never an invalid cut, never bad geometry; counted.
TEST(StreamRender, FaultsNeverProduceAnInvalidCut) {
  const test::StreamFixture& f = stream_fixture();
  const std::string json = test::stream_scene_json(f.path, 5, 12, 1.5, false);
  for (PageFault kind : {PageFault::kIoError, PageFault::kShortRead, PageFault::kCorrupt, PageFault::kSlow})
    for (bool always : {false, true}) {
      const uint64_t budget = f.pinned + (f.total - f.pinned) / 2;
      StreamOptions so = sync_stream();
      so.loader.slow_read_extra_ms = 0.2;
      // Non-pinned pages fail their first attempt (then load), or every attempt (marked bad).
      const std::vector<uint8_t> pinned = pinned_pages(read_container_metadata(f.path));
      so.loader.fault = [kind, pinned, always](uint32_t page, uint32_t attempt) {
        return !pinned[page] && (always || attempt == 0) ? kind : PageFault::kNone;
      };
      SceneFile file = load(json, budget, so);
      RenderRequest req;
      req.threads = 2;
      req.frames = 32;  // back-off 2+4+8 frames (+1 per read): the 4th failure marks a page bad
      FrameChecker check;
      check.file = &file;
      check.budget = budget;
      RenderReport r = render_scene(file, req, std::ref(check));
      ASSERT_FALSE(::testing::Test::HasFatalFailure()) << int(kind);
      uint64_t checksum = 0;
      for (const FrameStats& s : r.frames) checksum += s.stream.checksum_failures;
      if (kind == PageFault::kSlow) {
        EXPECT_EQ(r.stream.faults, 0u);
        EXPECT_GT(r.stream.pages_loaded, 0u);
        continue;
      }
      EXPECT_GT(r.stream.faults, 0u) << int(kind) << r.stream_table();
      if (always) {
        EXPECT_EQ(r.stream.pages_loaded, 0u) << int(kind);
        EXPECT_GT(r.stream.pages_marked_bad, 0u) << int(kind);
      } else {
        EXPECT_GT(r.stream.pages_loaded, 0u) << int(kind) << r.stream_table();
        EXPECT_EQ(r.stream.pages_marked_bad, 0u) << int(kind);
      }
      if (kind == PageFault::kCorrupt) {
        EXPECT_GT(checksum, 0u);
      }
    }
}

TEST(StreamRender, ByteSizes) {
  uint64_t v = 0;
  EXPECT_TRUE(parse_byte_size("64MiB", &v));
  EXPECT_EQ(v, 64ull << 20);
  EXPECT_TRUE(parse_byte_size("512KiB", &v));
  EXPECT_EQ(v, 512ull << 10);
  EXPECT_TRUE(parse_byte_size("1GB", &v));
  EXPECT_EQ(v, 1000000000ull);
  EXPECT_TRUE(parse_byte_size("4096", &v));
  EXPECT_EQ(v, 4096u);
  for (const char* bad : {"", "MiB", "-1", "1.5MiB", "64XB", "99999999999999999999", "8589934592GiB", "64 MiB"})
    EXPECT_FALSE(parse_byte_size(bad, &v)) << bad;
}

}  // namespace
}  // namespace vgeo
