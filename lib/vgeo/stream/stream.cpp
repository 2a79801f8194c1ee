// Page streaming: residency, requests, eviction and the resident cut (spec/stream.md).
// Based on: Karis, Stubbe, Wihlidal, "Nanite: A Deep Dive", SIGGRAPH 2021 Advances in
// Real-Time Rendering (fixed-size pages, root pages always resident, requests from the cut, the resident cut drawn meanwhile).
#include "vgeo/stream/stream.h"

#include <unistd.h>

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <limits>
#include <mutex>
#include <thread>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"

namespace vgeo {

// ---------------------------------------------------------------------------------------
// Selection

std::vector<uint8_t> usable_groups(const MeshMetadata& mesh, const std::vector<uint8_t>& page_resident) {
  const ClusterDag& dag = mesh.dag;
  const uint32_t ng = uint32_t(dag.groups.size());
  std::vector<uint8_t> resident(ng, 0);
  for (uint32_t g = 0; g < ng; ++g) {
    if (mesh.group_first_page[g] == kNone) continue;  // empty group: nothing to draw
    bool all = true;
    for (uint32_t p = mesh.group_first_page[g]; p < mesh.group_first_page[g] + mesh.group_page_count[g]; ++p)
      all = all && page_resident[p - mesh.first_page];
    resident[g] = all;
  }
  return usable_groups_of_resident(dag, std::move(resident));
}

std::vector<uint8_t> usable_groups_of_resident(const ClusterDag& dag, std::vector<uint8_t> usable) {
  const uint32_t ng = uint32_t(dag.groups.size());
  usable.resize(ng, 0);  // groups beyond the given mask are not resident
  // Greatest fixed point of usable[g] = resident(g) && usable[parent] for every parent.
  // Visiting coarse levels first settles a well-formed DAG in one sweep (+1 to confirm);
  // the loop only shrinks the set, so it terminates for any metadata.
  std::vector<uint32_t> order(ng);
  for (uint32_t g = 0; g < ng; ++g) order[g] = g;
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return dag.groups[a].level > dag.groups[b].level; });
  for (bool changed = true; changed;) {
    changed = false;
    for (uint32_t g : order) {
      if (!usable[g]) continue;
      const DagGroup& gr = dag.groups[g];
      for (uint32_t k = gr.first_generated; k < gr.first_generated + gr.generated_count; ++k) {
        const uint32_t parent = dag.clusters[dag.generated_clusters[k]].group;
        if (!usable[parent]) {
          usable[g] = 0;
          changed = true;
          break;
        }
      }
    }
  }
  return usable;
}

std::vector<uint32_t> select_resident_cut(const ClusterDag& dag, const std::vector<uint8_t>& usable,
                                          const LodView& view, float threshold_px) {
  const std::vector<uint8_t> all_usable(usable.empty() ? dag.groups.size() : 0, 1);
  const std::vector<uint8_t>& u = usable.empty() ? all_usable : usable;
  std::vector<uint32_t> cut;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const DagCluster& cl = dag.clusters[c];
    const float parent_px = projected_error(cl.parent_bounds, cl.parent_error, view);
    const float lod_px = projected_error(cl.lod_bounds, cl.lod_error, view);
    if (resident_lod_test(cl, u, parent_px, lod_px, threshold_px).drawn) cut.push_back(c);
  }
  return cut;
}

// ---------------------------------------------------------------------------------------
// Loader

struct Streamer::Completion {
  uint32_t page = 0;
  uint32_t attempt = 0;
  bool read_ok = false;
  std::string read_error;
  std::vector<uint8_t> bytes;
};

namespace {

// Reads one page's stored bytes (read_at), applying an injected fault. Never throws.
void read_page(int fd, const PageEntry& e, uint32_t page, uint32_t attempt, const LoaderOptions& lo,
               Streamer::Completion* out) {
  out->page = page;
  out->attempt = attempt;
  const PageFault fault = lo.fault ? lo.fault(page, attempt) : PageFault::kNone;
  double delay_ms = lo.latency_ms;
  if (lo.bandwidth_mb_s > 0) delay_ms += double(e.stored_size) / (lo.bandwidth_mb_s * 1e6) * 1e3;
  if (fault == PageFault::kSlow) delay_ms += lo.slow_read_extra_ms;
  if (delay_ms > 0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(delay_ms));
  if (fault == PageFault::kIoError) {
    out->read_error = "injected I/O error";
    return;
  }
  out->bytes.resize(e.stored_size);
  size_t want = e.stored_size;
  if (fault == PageFault::kShortRead) want = e.stored_size / 2;
  const int64_t got = read_at(fd, out->bytes.data(), want, e.file_offset);
  if (got < 0) {
    out->read_error = std::string("pread: ") + std::strerror(errno);
    return;
  }
  if (uint64_t(got) != e.stored_size) {
    out->read_error = "short read: " + std::to_string(got) + " of " + std::to_string(e.stored_size) + " bytes";
    return;
  }
  if (fault == PageFault::kCorrupt && !out->bytes.empty()) out->bytes[out->bytes.size() / 2] ^= 0x5A;
  out->read_ok = true;
}

}  // namespace

class PageLoader {
 public:
  PageLoader(const std::vector<int>& page_fd, const FormatContainer& container, const LoaderOptions& options)
      : page_fd_(page_fd), container_(container), options_(options) {
    if (options_.asynchronous) worker_ = std::thread([this] { run(); });
  }
  ~PageLoader() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
  }
  void issue(uint32_t page, uint32_t attempt) {
    if (!options_.asynchronous) {
      Streamer::Completion c;
      read_page(page_fd_[page], container_.pages[page], page, attempt, options_, &c);
      std::lock_guard<std::mutex> lock(mutex_);
      done_.push_back(std::move(c));
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back({page, attempt});
      ++pending_;
    }
    wake_.notify_all();
  }
  std::vector<Streamer::Completion> drain() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Streamer::Completion> out(std::make_move_iterator(done_.begin()), std::make_move_iterator(done_.end()));
    done_.clear();
    return out;
  }
  void wait_idle() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [this] { return pending_ == 0; });
  }

 private:
  void run() {
    for (;;) {
      std::pair<uint32_t, uint32_t> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        job = queue_.front();
        queue_.pop_front();
      }
      Streamer::Completion c;
      read_page(page_fd_[job.first], container_.pages[job.first], job.first, job.second, options_, &c);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        done_.push_back(std::move(c));
        --pending_;
      }
      idle_.notify_all();
    }
  }

  const std::vector<int>& page_fd_;
  const FormatContainer& container_;
  LoaderOptions options_;
  std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::deque<std::pair<uint32_t, uint32_t>> queue_;
  std::vector<Streamer::Completion> done_;
  uint32_t pending_ = 0;
  bool stop_ = false;
  std::thread worker_;
};

// ---------------------------------------------------------------------------------------
// Streamer

uint64_t total_page_bytes(const FormatContainer& container) {
  uint64_t sum = 0;
  for (const PageEntry& e : container.pages) sum += e.memory_size;
  return sum;
}

std::vector<uint8_t> pinned_pages(const FormatContainer& container) {
  std::vector<uint8_t> pinned(container.pages.size(), 0);
  for (const MeshMetadata& mm : container.meshes)
    for (uint32_t g = 0; g < mm.dag.groups.size(); ++g) {
      if (mm.group_first_page[g] == kNone) continue;
      if (mm.dag.groups[g].generated_count != 0 && !(mm.dag.groups[g].flags & kGroupTerminal)) continue;
      for (uint32_t p = mm.group_first_page[g]; p < mm.group_first_page[g] + mm.group_page_count[g]; ++p) pinned[p] = 1;
    }
  return pinned;
}

uint64_t pinned_page_bytes(const FormatContainer& container) {
  const std::vector<uint8_t> pinned = pinned_pages(container);
  uint64_t sum = 0;
  for (uint32_t p = 0; p < pinned.size(); ++p)
    if (pinned[p]) sum += container.pages[p].memory_size;
  return sum;
}

namespace {

// Projected errors are finite except for terminal groups; requests order by a finite key.
constexpr float kMaxPriority = std::numeric_limits<float>::max();

}  // namespace

Streamer::Streamer(const std::string& path, const StreamOptions& options)
    : Streamer(std::vector<std::string>{path}, options) {}

namespace {
std::vector<FormatContainer> read_all_metadata(const std::vector<std::string>& paths) {
  std::vector<FormatContainer> out;
  for (const std::string& path : paths) out.push_back(read_container_metadata(path));
  return out;
}
}  // namespace

Streamer::Streamer(const std::vector<std::string>& paths, const StreamOptions& options)
    : Streamer(paths, read_all_metadata(paths), options) {}

Streamer::Streamer(const std::vector<std::string>& paths, std::vector<FormatContainer> metadata,
                   const StreamOptions& options)
    : options_(options), paths_(paths), files_(std::move(metadata)) {
  if (files_.size() != paths_.size())
    fail("INTERNAL_SIZE_MISMATCH", "stream", "one metadata per page file expected", kExitInternal);
  auto close_all = [this] {
    for (int fd : fds_) ::close(fd);
    fds_.clear();
  };
  try {
    for (const std::string& path : paths_) {
      fds_.push_back(ReadOnlyFile(path).release());
    }
  } catch (...) {
    close_all();
    throw;
  }
  // The concatenation: page and mesh indices of file k shift by the counts of files < k.
  for (uint32_t k = 0; k < files_.size(); ++k) {
    const FormatContainer& f = files_[k];
    const uint32_t page_base = uint32_t(container_.pages.size()), mesh_base = uint32_t(container_.meshes.size());
    if (k == 0) {
      container_.version = f.version;
      container_.compression = f.compression;
      container_.page_size = f.page_size;
      container_.materials = f.materials;
      container_.instances = f.instances;
    }
    container_.file_size += f.file_size;
    container_.metadata_size += f.metadata_size;
    auto shift = [page_base](uint32_t& p) {
      if (p != kNone) p += page_base;
    };
    for (MeshMetadata mm : f.meshes) {
      mm.first_page += page_base;
      for (uint32_t& p : mm.cluster_page) shift(p);
      for (uint32_t& p : mm.group_first_page) shift(p);
      container_.meshes.push_back(std::move(mm));
    }
    for (uint32_t p = 0; p < f.pages.size(); ++p) {
      PageEntry e = f.pages[p];
      e.mesh += mesh_base;
      container_.pages.push_back(e);
      page_file_.push_back(k);
      page_local_.push_back(p);
      page_fd_.push_back(fds_[k]);
    }
  }
  const uint32_t np = uint32_t(container_.pages.size());
  state_.assign(np, PageState::kAbsent);
  pinned_ = pinned_pages(container_);
  words_.assign(np, {});
  attempts_.assign(np, 0);
  retry_frame_.assign(np, 0);
  last_wanted_frame_.assign(np, 0);
  priority_.assign(np, 0.0f);
  page_parents_.assign(np, {});
  page_children_.assign(np, {});
  for (const MeshMetadata& mm : container_.meshes) {
    const ClusterDag& dag = mm.dag;
    for (uint32_t g = 0; g < dag.groups.size(); ++g) {
      if (mm.group_first_page[g] == kNone) continue;
      const DagGroup& gr = dag.groups[g];
      for (uint32_t k = gr.first_generated; k < gr.first_generated + gr.generated_count; ++k) {
        const uint32_t h = dag.clusters[dag.generated_clusters[k]].group;
        if (mm.group_first_page[h] == kNone) continue;
        for (uint32_t q = mm.group_first_page[g]; q < mm.group_first_page[g] + mm.group_page_count[g]; ++q)
          for (uint32_t p = mm.group_first_page[h]; p < mm.group_first_page[h] + mm.group_page_count[h]; ++p)
            if (p != q) {
              page_parents_[q].push_back(p);
              page_children_[p].push_back(q);
            }
      }
    }
  }
  for (auto* lists : {&page_parents_, &page_children_})
    for (std::vector<uint32_t>& v : *lists) {
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
    }

  const uint64_t total = total_page_bytes(container_);
  active_ = total > options_.budget_bytes;
  const uint64_t pinned_bytes = pinned_page_bytes(container_);
  const std::string& path = paths_.size() == 1 ? paths_[0] : std::string("stream");
  if (active_ && pinned_bytes > options_.budget_bytes) {
    close_all();
    fail(kErrStreamBudget, path, "pinned root pages need " + std::to_string(pinned_bytes) + " bytes, budget is " +
                                     std::to_string(options_.budget_bytes));
  }
  // Start-up loads are synchronous: pinned pages when streaming, every page otherwise.
  LoaderOptions sync = options_.loader;
  sync.asynchronous = false;
  PageLoader boot(page_fd_, container_, sync);
  for (uint32_t p = 0; p < np; ++p) {
    if (active_ && !pinned_[p]) continue;
    while (state_[p] == PageState::kAbsent) {
      state_[p] = PageState::kInFlight;
      reserved_bytes_ += container_.pages[p].memory_size;
      boot.issue(p, attempts_[p]);
      std::vector<Completion> done = boot.drain();
      install(done.front(), nullptr);
    }
    if (state_[p] == PageState::kBad && pinned_[p]) {
      close_all();
      fail(kErrStreamRootPage, paths_[page_file_[p]], "pinned page " + std::to_string(p) + " failed " +
                                         std::to_string(options_.max_attempts) + " times");
    }
  }
  if (active_) loader_ = std::make_unique<PageLoader>(page_fd_, container_, options_.loader);
}

Streamer::~Streamer() {
  loader_.reset();  // joins the worker before the descriptor closes
  for (int fd : fds_) ::close(fd);
}

void Streamer::wait_idle() {
  if (loader_) loader_->wait_idle();
}

std::vector<uint8_t> Streamer::usable(uint32_t mesh) const {
  const MeshMetadata& mm = container_.meshes[mesh];
  std::vector<uint8_t> resident(mm.page_count);
  for (uint32_t k = 0; k < mm.page_count; ++k) resident[k] = state_[mm.first_page + k] == PageState::kResident;
  return usable_groups(mm, resident);
}

void Streamer::install(Completion& c, StreamFrameStats* stats) {
  const uint32_t p = c.page;
  const PageEntry& e = container_.pages[p];
  bool ok = false;
  if (!c.read_ok) {
    totals_.read_failures++;
    if (stats) stats->read_failures++;
  } else {
    totals_.bytes_read += c.bytes.size();
    if (stats) stats->bytes_read += c.bytes.size();
    try {
      const std::string& where = paths_[page_file_[p]];
      std::vector<uint32_t> words =
          transcode_page(files_[page_file_[p]], page_local_[p], c.bytes.data(), c.bytes.size(), where);
      validate_memory_page(words.data(), words.size(), container_.meshes[e.mesh].quantization, where);
      words_[p] = std::move(words);
      ok = true;
    } catch (const VgeoError& err) {
      if (err.error().code == kErrChecksum) {
        totals_.checksum_failures++;
        if (stats) stats->checksum_failures++;
      } else {
        totals_.decode_failures++;
        if (stats) stats->decode_failures++;
      }
    }
  }
  if (ok) {
    state_[p] = PageState::kResident;
    resident_bytes_ += e.memory_size;
    totals_.pages_loaded++;
    if (stats) stats->pages_loaded++;
    return;
  }
  reserved_bytes_ -= e.memory_size;
  attempts_[p]++;
  if (attempts_[p] >= options_.max_attempts) {
    state_[p] = PageState::kBad;
    totals_.pages_marked_bad++;
    if (stats) stats->pages_marked_bad++;
  } else {
    state_[p] = PageState::kAbsent;
    retry_frame_[p] = frame_ + (uint64_t(1) << attempts_[p]);  // exponential back-off in frames
  }
}

bool page_evictable(const EvictionView& v, uint32_t page) {
  if (v.state[page] != PageState::kResident || v.pinned[page]) return false;
  for (uint32_t q : v.page_children[page])
    if (v.state[q] == PageState::kResident) return false;  // a resident child group depends on it
  return true;
}

uint32_t choose_eviction_victim(const EvictionView& v) {
  auto key_less = [&](uint32_t a, uint32_t b) {
    const bool wa = v.last_wanted_frame[a] == v.frame, wb = v.last_wanted_frame[b] == v.frame;
    if (wa != wb) return !wa;
    if (!wa && v.last_wanted_frame[a] != v.last_wanted_frame[b]) return v.last_wanted_frame[a] < v.last_wanted_frame[b];
    if (v.priority[a] != v.priority[b]) return v.priority[a] < v.priority[b];
    return a > b;  // finer data (placed later) goes first
  };
  uint32_t victim = kNone;
  for (uint32_t q = 0; q < uint32_t(v.state.size()); ++q)
    if (page_evictable(v, q) && (victim == kNone || key_less(q, victim))) victim = q;
  return victim;
}

void Streamer::evict(uint32_t page, StreamFrameStats* stats) {
  state_[page] = PageState::kAbsent;
  words_[page] = {};
  resident_bytes_ -= container_.pages[page].memory_size;
  reserved_bytes_ -= container_.pages[page].memory_size;
  totals_.pages_evicted++;
  stats->pages_evicted++;
}

StreamFrameStats Streamer::begin_frame() {
  ++frame_;
  StreamFrameStats stats;
  stats.frame = frame_;
  stats.active = active_;
  totals_.frames++;
  if (!active_) return stats;
  for (Completion& c : loader_->drain()) {
    in_flight_--;
    install(c, &stats);
  }
  return stats;
}

void Streamer::end_frame(const std::vector<GroupRequest>& requests, StreamFrameStats* out) {
  StreamFrameStats& stats = *out;
  const uint32_t np = uint32_t(container_.pages.size());
  if (active_) {
    // Requests, then their coarser ancestors (dependencies).
    std::vector<float> page_priority(np, -1.0f);  // < 0: not wanted
    std::vector<std::vector<float>> group_priority(container_.meshes.size());
    for (const GroupRequest& r : requests) {
      assert(r.mesh < container_.meshes.size() && r.group < container_.meshes[r.mesh].dag.groups.size());
      std::vector<float>& gp = group_priority[r.mesh];
      gp.resize(container_.meshes[r.mesh].dag.groups.size(), -1.0f);
      gp[r.group] = std::max(gp[r.group], std::min(r.priority, kMaxPriority));
    }
    for (uint32_t m = 0; m < container_.meshes.size(); ++m) {
      std::vector<float>& gp = group_priority[m];
      if (gp.empty()) continue;
      const MeshMetadata& mm = container_.meshes[m];
      const ClusterDag& dag = mm.dag;
      // Finer groups first, so a parent inherits the max priority of its children and is
      // loaded no later than them. Level order is re-derived (untrusted metadata).
      std::vector<uint32_t> order(dag.groups.size());
      for (uint32_t g = 0; g < order.size(); ++g) order[g] = g;
      std::stable_sort(order.begin(), order.end(),
                       [&](uint32_t a, uint32_t b) { return dag.groups[a].level < dag.groups[b].level; });
      for (uint32_t g : order) {
        if (gp[g] < 0) continue;
        const DagGroup& gr = dag.groups[g];
        for (uint32_t k = gr.first_generated; k < gr.first_generated + gr.generated_count; ++k) {
          const uint32_t h = dag.clusters[dag.generated_clusters[k]].group;
          gp[h] = std::max(gp[h], gp[g]);
        }
      }
      for (uint32_t g = 0; g < gp.size(); ++g) {
        if (gp[g] < 0 || mm.group_first_page[g] == kNone) continue;
        for (uint32_t p = mm.group_first_page[g]; p < mm.group_first_page[g] + mm.group_page_count[g]; ++p)
          page_priority[p] = std::max(page_priority[p], gp[g]);
      }
    }
    std::vector<uint32_t> candidates;
    for (uint32_t p = 0; p < np; ++p) {
      if (page_priority[p] < 0) continue;
      stats.pages_requested++;
      last_wanted_frame_[p] = frame_;
      priority_[p] = page_priority[p];
      if (state_[p] != PageState::kResident) stats.pages_missing++;
      if (state_[p] == PageState::kAbsent && retry_frame_[p] <= frame_) candidates.push_back(p);
    }
    {
      std::vector<uint8_t> need(np, 0);
      std::vector<uint32_t> stack;
      for (uint32_t p = 0; p < np; ++p)
        if (page_priority[p] >= 0 || pinned_[p]) {
          need[p] = 1;
          stack.push_back(p);
        }
      while (!stack.empty()) {
        const uint32_t p = stack.back();
        stack.pop_back();
        for (uint32_t q : page_parents_[p])
          if (!need[q]) {
            need[q] = 1;
            stack.push_back(q);
          }
      }
      for (uint32_t p = 0; p < np; ++p) {
        if (need[p]) stats.required_bytes += container_.pages[p].memory_size;
        if (page_priority[p] >= 0) stats.requested_bytes += container_.pages[p].memory_size;
      }
    }
    // Highest priority first; ties: lower page index (coarser data is placed first).
    std::sort(candidates.begin(), candidates.end(), [&](uint32_t a, uint32_t b) {
      return page_priority[a] != page_priority[b] ? page_priority[a] > page_priority[b] : a < b;
    });
    // Issue, evicting the lowest-priority evictable pages: not wanted this frame first
    // (least recently wanted first), then wanted pages of strictly lower priority.
    for (uint32_t p : candidates) {
      if (stats.pages_issued >= options_.max_issues_per_frame || in_flight_ >= options_.max_in_flight) break;
      const uint64_t size = container_.pages[p].memory_size;
      if (size > options_.budget_bytes) continue;
      bool room = true;
      while (reserved_bytes_ + size > options_.budget_bytes) {
        const uint32_t victim = choose_eviction_victim(eviction_view());
        const bool victim_lower = victim != kNone && (last_wanted_frame_[victim] != frame_ ||
                                                      priority_[victim] < page_priority[p]);
        if (!victim_lower) {
          room = false;
          break;
        }
        evict(victim, &stats);
      }
      if (!room) break;
      state_[p] = PageState::kInFlight;
      reserved_bytes_ += size;
      in_flight_++;
      stats.pages_issued++;
      loader_->issue(p, attempts_[p]);
    }
  }
  stats.resident_bytes = resident_bytes_;
  stats.reserved_bytes = reserved_bytes_;
  stats.resident_pages = 0;
  for (uint32_t p = 0; p < np; ++p) stats.resident_pages += state_[p] == PageState::kResident;
}

StreamFrameStats Streamer::update(const std::vector<StreamView>& views, std::vector<std::vector<uint32_t>>* cuts) {
  StreamFrameStats stats = begin_frame();
  // Requests: the groups of the ideal cut (flat LOD test of every cluster of each view).
  std::vector<std::vector<uint32_t>> ideal(views.size());
  std::vector<GroupRequest> requests;
  for (size_t v = 0; v < views.size(); ++v) {
    const ClusterDag& dag = container_.meshes[views[v].mesh].dag;
    ideal[v] = select_resident_cut(dag, {}, views[v].view, options_.threshold_px);
    if (!active_) continue;
    for (uint32_t c : ideal[v]) {
      const DagCluster& cl = dag.clusters[c];
      requests.push_back({views[v].mesh, cl.group, projected_error(cl.parent_bounds, cl.parent_error, views[v].view)});
    }
  }
  end_frame(requests, &stats);
  // The drawn cut from usable groups only.
  if (cuts) cuts->assign(views.size(), {});
  stats.cut_is_ideal = true;
  for (size_t v = 0; v < views.size(); ++v) {
    const uint32_t m = views[v].mesh;
    const ClusterDag& dag = container_.meshes[m].dag;
    std::vector<uint32_t> cut = select_resident_cut(dag, usable(m), views[v].view, options_.threshold_px);
    if (cut != ideal[v]) {
      stats.cut_is_ideal = false;
      std::vector<uint32_t> missing;
      std::set_difference(ideal[v].begin(), ideal[v].end(), cut.begin(), cut.end(), std::back_inserter(missing));
      stats.clusters_coarser += uint32_t(missing.size());
    }
    stats.clusters_drawn += uint32_t(cut.size());
    if (cuts) (*cuts)[v] = std::move(cut);
  }
  if (!stats.cut_is_ideal) totals_.frames_coarser++;
  return stats;
}

}  // namespace vgeo
