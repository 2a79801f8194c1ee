// `vgeo conform decoder [--vectors DIR] [--mutants N] [--seed S] [--out DIR] [--junit F]
// [--timeout S] [--strict-codes] -- CMD ARGS...`: differential testing of another page decoder
// (spec/conform.md §5). CMD ARGS FILE prints one line — the decode hash (16 lowercase hex
// digits) or `error[CODE]` — for every vector of DIR/manifest.txt and N seeded mutants of its
// valid files; vgeo compares with its own decoder and saves a reproducer for each disagreement.
// `vgeo conform hash FILE` is vgeo's own decoder behind the same protocol.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <functional>
#include <sstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "conform.h"
#include "junit.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"
#include "vgeo/core/progress.h"
#include "vgeo/dag/dag_io.h"
#include "vgeo/format/asset_file.h"
#include "vgeo/format/decode_hash.h"
#include "vgeo/format/format.h"
#include "vgeo/format/format_edit.h"
#include "vgeo/format/lz4_block.h"

namespace vgeo::cli {

namespace {

constexpr size_t kMaxVerdictBytes = 4096;  // a verdict is one short line; more is a protocol error

// A decoder's answer: accepted with a hash, rejected with a code, or no valid answer.
struct Verdict {
  enum Kind { kAccept, kReject, kProtocol } kind = kProtocol;
  std::string value;  // hash (16 hex), code, or what went wrong
  std::string reason;  // vgeo's own rejections: the error's `where: what` (not compared)
  std::string text() const {
    return kind == kAccept ? value : kind == kReject ? "error[" + value + "]" : "protocol: " + value;
  }
};

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", s);
  return buf;
}

std::string hash_text(uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

Verdict our_verdict(const std::vector<uint8_t>& bytes, const std::string& where = "<conform>") {
  Verdict v;
  try {
    v.value = hash_text(decode_hash(decode_format(bytes.data(), bytes.size(), where)));
    v.kind = Verdict::kAccept;
  } catch (const VgeoError& e) {
    v.kind = Verdict::kReject;
    v.value = e.error().code;
    v.reason = e.error().where + ": " + e.error().what;
  } catch (const std::bad_alloc&) {
    v.kind = Verdict::kReject;
    v.value = "OUT_OF_MEMORY";
    v.reason = "allocation failed";
  }
  return v;
}

// The VGEODAG1 reader behind the same protocol (spec/format.md §9, "VGEODAG1 decode hash").
Verdict our_dag_verdict(const std::vector<uint8_t>& bytes, const std::string& where) {
  Verdict v;
  try {
    v.value = hash_text(decode_hash(decode_dag_file(bytes.data(), bytes.size(), where)));
    v.kind = Verdict::kAccept;
  } catch (const VgeoError& e) {
    v.kind = Verdict::kReject;
    v.value = e.error().code;
    v.reason = e.error().where + ": " + e.error().what;
  }
  return v;
}

// Parses the first line of CMD's stdout (spec/conform.md §5.1).
Verdict parse_verdict(const std::string& out) {
  Verdict v;
  std::string line = out.substr(0, out.find('\n'));
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line.size() == 16 && line.find_first_not_of("0123456789abcdef") == std::string::npos) {
    v.kind = Verdict::kAccept, v.value = line;
  } else if (line.size() > 7 && line.rfind("error[", 0) == 0 && line.back() == ']') {
    v.kind = Verdict::kReject, v.value = line.substr(6, line.size() - 7);
  } else {
    v.value = "first line is neither 16 hex digits nor error[CODE]: '" + line.substr(0, 80) + "'";
  }
  return v;
}

// The tail of a decoder's stderr kept to explain a protocol failure (a crash message, a usage
// error): enough for the last few lines, bounded so a chatty decoder costs nothing.
constexpr size_t kStderrTailBytes = 2048, kStderrShownChars = 300;

// The last lines of `tail`, newlines shown as " | ", at most kStderrShownChars.
std::string stderr_summary(std::string tail) {
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == '\r')) tail.pop_back();
  if (tail.size() > kStderrShownChars) tail = "..." + tail.substr(tail.size() - kStderrShownChars);
  std::string out;
  for (char c : tail) {
    if (c == '\n') out += " | ";
    else if (c != '\r') out += (static_cast<unsigned char>(c) < 0x20 && c != '\t') ? '?' : c;
  }
  return out;
}

// Runs CMD ARGS FILE with stdout captured (the verdict) and the tail of stderr kept (shown with
// a protocol failure), killed after `timeout_s`.
Verdict run_decoder(const std::vector<std::string>& command, const std::string& file, double timeout_s) {
  int out_fds[2], err_fds[2];
  if (pipe(out_fds) != 0) return {Verdict::kProtocol, "pipe failed", ""};
  if (pipe(err_fds) != 0) {
    close(out_fds[0]), close(out_fds[1]);
    return {Verdict::kProtocol, "pipe failed", ""};
  }
  pid_t pid = fork();
  if (pid < 0) {
    close(out_fds[0]), close(out_fds[1]), close(err_fds[0]), close(err_fds[1]);
    return {Verdict::kProtocol, "fork failed", ""};
  }
  if (pid == 0) {
    dup2(out_fds[1], STDOUT_FILENO);
    dup2(err_fds[1], STDERR_FILENO);
    int null_fd = open("/dev/null", O_RDONLY);
    if (null_fd >= 0) dup2(null_fd, STDIN_FILENO);
    close(out_fds[0]), close(out_fds[1]), close(err_fds[0]), close(err_fds[1]);
    std::vector<char*> argv;
    for (const std::string& a : command) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(const_cast<char*>(file.c_str()));
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    std::fprintf(stderr, "cannot run %s: %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  close(out_fds[1]), close(err_fds[1]);
  std::string out, err;
  bool timed_out = false, out_open = true, err_open = true;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  auto ms_left = [&] {
    return std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
  };
  while (out_open || err_open) {
    const auto left = ms_left();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    pollfd p[2] = {{out_open ? out_fds[0] : -1, POLLIN, 0}, {err_open ? err_fds[0] : -1, POLLIN, 0}};
    if (poll(p, 2, int(left)) <= 0) continue;
    char buf[1024];
    if (out_open && (p[0].revents & (POLLIN | POLLHUP | POLLERR))) {
      const ssize_t n = read(out_fds[0], buf, sizeof buf);
      if (n <= 0) out_open = false;
      else if (out.size() < kMaxVerdictBytes) out.append(buf, size_t(n));
    }
    if (err_open && (p[1].revents & (POLLIN | POLLHUP | POLLERR))) {
      const ssize_t n = read(err_fds[0], buf, sizeof buf);
      if (n <= 0) err_open = false;
      else if ((err += std::string(buf, size_t(n))).size() > kStderrTailBytes) err.erase(0, err.size() - kStderrTailBytes);
    }
  }
  close(out_fds[0]), close(err_fds[0]);
  // Both streams closed: the process is ending; wait for it, but not past the deadline.
  int status = 0;
  for (;;) {
    if (timed_out) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      break;
    }
    const pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid || done < 0) break;
    if (ms_left() <= 0) timed_out = true;
    else usleep(1000);
  }
  Verdict v;
  if (timed_out) v = {Verdict::kProtocol, "no verdict within the timeout", ""};
  else if (WIFSIGNALED(status)) v = {Verdict::kProtocol, "killed by signal " + std::to_string(WTERMSIG(status)), ""};
  else if (WIFEXITED(status) && WEXITSTATUS(status) == 127 && out.empty()) v = {Verdict::kProtocol, "cannot run the command", ""};
  else v = parse_verdict(out);
  if (v.kind == Verdict::kProtocol && !err.empty()) v.value += "; stderr: " + stderr_summary(err);
  return v;
}

// Deterministic mutations (SplitMix64; spec/conform.md §5.2).
struct Rng {
  uint64_t state;
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  size_t below(size_t n) { return n == 0 ? 0 : size_t(next() % n); }
};

// Byte-level kinds (0-5) see mostly the CRC and length checks; the structure-aware kinds (6-9)
// edit a metadata field, a raw page field, a raw page's length, or a compressed stream's own
// bytes, then fix every size and checksum (lib/vgeo/format/format_edit.h), so the decoder's
// deeper rules — and its decompressors — are reached.
const char* const kMutationKinds[] = {"truncate", "bitflip", "byte", "splice", "duplicate", "delete",
                                      "field", "page-field", "page-length", "stream"};
constexpr size_t kByteMutationKinds = 6, kMutationKindCount = 10;
constexpr size_t kKindField = 6, kKindPageLength = 8, kKindStream = 9;

// A boundary value for a u32 field that held `old`.
uint32_t boundary_value(uint32_t old, Rng& rng) {
  switch (rng.below(8)) {
    case 0: return 0;
    case 1: return 1;
    case 2: return old + 1;
    case 3: return old - 1;
    case 4: return 0xFFFFFFFFu;
    case 5: return old * 2;
    case 6: return old ^ (1u << rng.below(32));
    default: return uint32_t(rng.next());
  }
}

// One u32 of the metadata (mesh header, a record of any array, the page count) set to a
// boundary value.
bool mutate_metadata_field(std::vector<uint8_t>& m, Rng& rng) {
  return edit_metadata(m, [&](std::vector<uint8_t>& raw, const MetaLayout& L) {
    std::vector<const MetaArray*> arrays = {&L.instances, &L.pages};
    for (const MetaLayout::Mesh& mesh : L.meshes)
      for (const MetaArray* a : {&mesh.clusters, &mesh.groups, &mesh.generated, &mesh.bvh, &mesh.page_clusters})
        if (a->count > 0) arrays.push_back(a);
    const size_t pick = rng.below(arrays.size() + L.meshes.size() + 1);
    if (pick < arrays.size() && arrays[pick]->count > 0) {
      const MetaArray& a = *arrays[pick];
      const uint32_t i = uint32_t(rng.below(a.count)), field = 4 * uint32_t(rng.below(a.record_size / 4));
      meta_put32(raw, a, i, field, boundary_value(meta_get32(raw, a, i, field), rng));
    } else {
      const size_t at = pick >= arrays.size() + L.meshes.size() || L.meshes.empty()
                            ? L.page_count_at
                            : L.meshes[pick - arrays.size()].header_at + 4 * rng.below(kMetaMeshHeaderBytes / 4);
      put_le32_at(&raw[at], boundary_value(le32_at(&raw[at]), rng));
    }
  });
}

// A raw page field (cluster counts, bits, mins, strip control, reference total or bytes,
// material runs) or the page's length (1-4 bytes inserted or removed), page recompressed.
bool mutate_page(std::vector<uint8_t>& m, Rng& rng, bool length) {
  uint32_t channels = 0, page = 0;
  try {
    const FormatContainer fc = parse_container(m.data(), m.size(), "<mutant>");
    if (fc.pages.empty()) return false;
    page = uint32_t(rng.below(fc.pages.size()));
    channels = fc.meshes[fc.pages[page].mesh].quantization.channel_count();
  } catch (const VgeoError&) {
    return false;
  }
  return edit_raw_page(m, page, [&](std::vector<uint8_t>& raw) {
    RawPageLayout L;
    if (raw.size() < 8 || !raw_page_layout(raw, channels, &L)) return;
    if (length) {
      const size_t at = rng.below(raw.size() + 1), n = 1 + rng.below(4);
      if (rng.below(2) && at + n <= raw.size()) raw.erase(raw.begin() + long(at), raw.begin() + long(at + n));
      else raw.insert(raw.begin() + long(std::min(at, raw.size())), n, uint8_t(rng.next()));
      return;
    }
    auto byte_in = [&](size_t from, uint64_t count) {
      if (count == 0) return;
      uint8_t& b = raw[from + rng.below(size_t(count))];
      b = rng.below(2) ? uint8_t(b ^ (1u << rng.below(8))) : uint8_t(boundary_value(b, rng));
    };
    auto u32_in = [&](size_t from, uint64_t count) {
      if (count == 0) return;
      const size_t at = from + 4 * rng.below(size_t(count));
      put_le32_at(&raw[at], boundary_value(le32_at(&raw[at]), rng));
    };
    switch (rng.below(7)) {
      case 0: byte_in(L.counts, 3ull * L.n); break;
      case 1: byte_in(L.bits, uint64_t(L.n) * channels); break;
      case 2: u32_in(L.mins, uint64_t(L.n) * channels); break;
      case 3: byte_in(L.ctl, L.triangles); break;
      case 4: u32_in(L.ref_total, 1); break;
      case 5: byte_in(L.refs, L.run_start - L.refs); break;
      default: rng.below(2) ? byte_in(L.run_start, L.runs) : u32_in(L.run_material, L.runs); break;
    }
  });
}

// One lz4 block edited at a sequence (lz4's doc/lz4_Block_format.md): the match offset (0,
// 1, ±1, exactly the output written so far — the output start — or one more, 0xFFFF, random),
// the token's literal or match nibble, a length byte, a literal, or the block cut at or
// extended after a sequence. A block that does not parse gets a bit flip.
void mutate_lz4_block(std::vector<uint8_t>& b, Rng& rng) {
  std::vector<Lz4Sequence> seqs;
  std::vector<uint64_t> written;  // output bytes before each sequence's match
  uint64_t out = 0;
  walk_lz4_block(b.data(), b.size(), [&](const Lz4Sequence& q) {
    out += q.literal_count;
    seqs.push_back(q), written.push_back(out);
    out += q.match_length;
    return true;
  });
  if (seqs.empty() || b.empty()) {
    if (!b.empty()) b[rng.below(b.size())] ^= uint8_t(1u << rng.below(8));
    return;
  }
  const size_t i = rng.below(seqs.size());
  const Lz4Sequence& q = seqs[i];
  switch (rng.below(6)) {
    case 0:
      if (q.has_match) {
        const uint64_t at = written[i];
        const uint32_t choices[] = {0, 1, q.offset - 1, q.offset + 1, uint32_t(at), uint32_t(at + 1), 0xFFFF,
                                    uint32_t(rng.next())};
        const uint32_t o = choices[rng.below(8)] & 0xFFFFu;
        b[q.offset_at] = uint8_t(o), b[q.offset_at + 1] = uint8_t(o >> 8);
        break;
      }
      [[fallthrough]];
    case 1: {  // a nibble of the token: ±1, 0, 15 or random
      const int shift = rng.below(2) ? 4 : 0;
      const uint32_t old = (b[q.token_at] >> shift) & 15u;
      const uint32_t choices[] = {old + 1, old - 1, 0, 15, uint32_t(rng.below(16))};
      const uint32_t v = choices[rng.below(5)] & 15u;
      b[q.token_at] = uint8_t((b[q.token_at] & ~(15u << shift)) | (v << shift));
      break;
    }
    case 2: {  // a length byte (literal or match), else the token
      std::vector<size_t> at;
      for (size_t k = q.token_at + 1; k < q.literals_at; ++k) at.push_back(k);
      if (q.has_match)
        for (size_t k = q.offset_at + 2; k < q.end; ++k) at.push_back(k);
      const size_t k = at.empty() ? q.token_at : at[rng.below(at.size())];
      const uint8_t choices[] = {0, 254, 255, uint8_t(b[k] + 1), uint8_t(b[k] - 1), uint8_t(rng.next())};
      b[k] = choices[rng.below(6)];
      break;
    }
    case 3:  // a literal (the output changes: a hash to compare)
      if (q.literal_count > 0) {
        b[q.literals_at + rng.below(q.literal_count)] ^= uint8_t(1u << rng.below(8));
        break;
      }
      [[fallthrough]];
    case 4:  // cut at the sequence's token, or inside it
      b.resize(rng.below(2) ? q.token_at : q.token_at + rng.below(q.end - q.token_at + 1));
      break;
    default: {  // bytes appended, or a sequence repeated (the output grows)
      if (rng.below(2)) {
        for (size_t k = 0, n = 1 + rng.below(4); k < n; ++k) b.push_back(uint8_t(rng.next()));
      } else {
        const std::vector<uint8_t> copy(b.begin() + long(q.token_at), b.begin() + long(q.end));
        b.insert(b.begin() + long(q.token_at), copy.begin(), copy.end());
      }
      break;
    }
  }
}

// One zstd frame edited (RFC 8878): a byte of the magic or the frame header descriptor, of the
// rest of the frame header (window, dictionary id, content size), of a block header (last
// flag, type, size), of a block's content, or of the content checksum; or the frame cut or
// extended. Positions come from a walk of the frame header and the block headers.
void mutate_zstd_frame(std::vector<uint8_t>& f, Rng& rng) {
  constexpr size_t kMagicBytes = 4, kBlockHeaderBytes = 3, kChecksumBytes = 4;
  auto flip = [&](size_t at) {
    uint8_t& x = f[at];
    x = rng.below(2) ? uint8_t(x ^ (1u << rng.below(8))) : uint8_t(boundary_value(x, rng));
  };
  if (f.size() <= kMagicBytes) {
    if (!f.empty()) flip(rng.below(f.size()));
    return;
  }
  const uint8_t fhd = f[kMagicBytes];
  const uint32_t fcs_flag = fhd >> 6, single_segment = (fhd >> 5) & 1u, checksum = (fhd >> 2) & 1u,
                 dict_flag = fhd & 3u;
  static const size_t kDictBytes[] = {0, 1, 2, 4}, kFcsBytes[] = {0, 2, 4, 8};
  const size_t fcs = fcs_flag == 0 ? single_segment : kFcsBytes[fcs_flag];
  const size_t header_end = std::min(f.size(), kMagicBytes + 1 + (single_segment ? 0 : 1) + kDictBytes[dict_flag] + fcs);
  std::vector<size_t> block_headers;
  std::vector<std::pair<size_t, size_t>> contents;
  size_t at = header_end;
  while (at + kBlockHeaderBytes <= f.size()) {
    const uint32_t bh = uint32_t(f[at]) | uint32_t(f[at + 1]) << 8 | uint32_t(f[at + 2]) << 16;
    block_headers.push_back(at);
    const size_t type = (bh >> 1) & 3u, size = type == 1 ? 1 : (bh >> 3);
    at += kBlockHeaderBytes;
    contents.push_back({at, std::min(size, f.size() - at)});
    at += size;
    if ((bh & 1u) || at >= f.size()) break;
  }
  const bool has_checksum = checksum && at + kChecksumBytes <= f.size();
  switch (rng.below(6)) {
    case 0: flip(rng.below(kMagicBytes + 1)); break;
    case 1: flip(header_end > kMagicBytes + 1 ? kMagicBytes + 1 + rng.below(header_end - kMagicBytes - 1) : kMagicBytes); break;
    case 2:
      if (!block_headers.empty()) {
        flip(block_headers[rng.below(block_headers.size())] + rng.below(kBlockHeaderBytes));
        break;
      }
      [[fallthrough]];
    case 3: {
      std::vector<size_t> with_bytes;
      for (size_t k = 0; k < contents.size(); ++k)
        if (contents[k].second > 0) with_bytes.push_back(k);
      if (!with_bytes.empty()) {
        const auto& c = contents[with_bytes[rng.below(with_bytes.size())]];
        flip(c.first + rng.below(c.second));
      } else {
        flip(rng.below(f.size()));
      }
      break;
    }
    case 4:
      flip(has_checksum ? at + rng.below(kChecksumBytes) : rng.below(f.size()));
      break;
    default:
      if (rng.below(2)) f.resize(rng.below(f.size()));
      else f.push_back(uint8_t(rng.next()));
      break;
  }
}

// A compressed stream of the file — a random page's stored bytes, or the stored metadata when
// it is compressed ([v2]) — edited by its codec's mutator, then every size and CRC fixed
// (lib/vgeo/format/format_edit.h), so that the edit reaches the decompressors of
// spec/format.md §5.1. False when the file has no compressed stream this can reach.
bool mutate_stream(std::vector<uint8_t>& m, Rng& rng) {
  constexpr size_t kHeaderBytes = 64;
  if (m.size() < kHeaderBytes) return false;
  const uint32_t version = le32_at(&m[8]);
  const Compression pages = Compression(le32_at(&m[24]));
  const Compression meta = version >= 2 ? Compression(le32_at(&m[48])) : Compression::kNone;
  auto usable = [](Compression c) { return c == Compression::kZstd || c == Compression::kLz4; };
  auto edit = [&](Compression c) {
    return [&rng, c](std::vector<uint8_t>& stream) {
      if (c == Compression::kLz4) mutate_lz4_block(stream, rng);
      else mutate_zstd_frame(stream, rng);
    };
  };
  uint32_t page_count = 0;
  try {
    page_count = uint32_t(parse_container(m.data(), m.size(), "<mutant>").pages.size());
  } catch (const VgeoError&) {
    return false;
  }
  // The metadata one time in four when both are compressed (a file has one metadata, many pages).
  if (usable(meta) && (!usable(pages) || page_count == 0 || rng.below(4) == 0)) return edit_stored_metadata(m, edit(meta));
  if (!usable(pages) || page_count == 0) return false;
  return edit_stored_page(m, uint32_t(rng.below(page_count)), edit(pages), false);
}

std::vector<uint8_t> mutate(const std::vector<std::vector<uint8_t>>& sources, Rng& rng, std::string* kind) {
  const std::vector<uint8_t>& src = sources[rng.below(sources.size())];
  std::vector<uint8_t> m = src;
  const size_t k = rng.below(kMutationKindCount);
  *kind = kMutationKinds[k];
  if (m.empty()) return m;
  if (k >= kByteMutationKinds) {
    // A source this module cannot edit (not one of ours) falls back to a bit flip.
    bool ok = false;
    if (k == kKindStream) {
      // Only compressed files have streams: up to kStreamSourceTries sources are drawn.
      constexpr int kStreamSourceTries = 8;
      ok = mutate_stream(m, rng);
      for (int t = 1; !ok && t < kStreamSourceTries; ++t) {
        m = sources[rng.below(sources.size())];
        ok = mutate_stream(m, rng);
      }
    } else {
      ok = k == kKindField ? mutate_metadata_field(m, rng) : mutate_page(m, rng, k == kKindPageLength);
    }
    if (ok) return m;
    m = src;
    *kind = kMutationKinds[1];
  }
  switch (k >= kByteMutationKinds ? 1 : k) {
    case 0: m.resize(rng.below(m.size())); break;
    case 1:
      for (size_t i = 0, n = 1 + rng.below(4); i < n; ++i) m[rng.below(m.size())] ^= uint8_t(1u << rng.below(8));
      break;
    case 2: {
      static const uint8_t kValues[] = {0x00, 0xFF, 0x7F, 0x80, 0x01};
      size_t at = rng.below(m.size());
      m[at] = rng.below(2) ? kValues[rng.below(5)] : uint8_t(rng.next());
      break;
    }
    case 3: {  // a range of another valid file over a range of this one
      const std::vector<uint8_t>& other = sources[rng.below(sources.size())];
      size_t from = rng.below(other.size()), len = 1 + rng.below(std::min<size_t>(256, other.size() - from));
      size_t at = rng.below(m.size());
      for (size_t i = 0; i < len && at + i < m.size(); ++i) m[at + i] = other[from + i];
      break;
    }
    case 4: {  // a range repeated in place (lengths and offsets now point elsewhere)
      size_t from = rng.below(m.size()), len = 1 + rng.below(std::min<size_t>(64, m.size() - from));
      m.insert(m.begin() + std::ptrdiff_t(from), src.begin() + std::ptrdiff_t(from), src.begin() + std::ptrdiff_t(from + len));
      break;
    }
    default: {
      size_t from = rng.below(m.size()), len = 1 + rng.below(std::min<size_t>(64, m.size() - from));
      m.erase(m.begin() + std::ptrdiff_t(from), m.begin() + std::ptrdiff_t(from + len));
      break;
    }
  }
  return m;
}

std::vector<uint8_t> read_bytes(const std::string& path) { return read_conform_file(path, kAnyFileSize, "a vector"); }

// The disagreement between two verdicts (spec/conform.md §5.3): "" when they agree.
std::string disagreement(const Verdict& ours, const Verdict& theirs) {
  if (theirs.kind == Verdict::kProtocol) return "protocol";
  if (ours.kind != theirs.kind) return "verdict";
  if (ours.value != theirs.value) return ours.kind == Verdict::kAccept ? "hash" : "code";
  return "";
}

// The stored page whose bytes hold [at, at + len) entirely, if any (walking the page table of
// the file's raw metadata).
bool page_holding(const std::vector<uint8_t>& f, size_t at, size_t len, uint32_t* page, size_t* page_at) {
  std::vector<uint8_t> raw;
  MetaLayout L;
  if (f.size() < 64 || !raw_metadata(f, &raw) || !walk_metadata(raw, le32_at(&f[8]), &L)) return false;
  size_t offset = 0;
  for (uint32_t p = 0; p < L.pages.count && page_offset(f, p, &offset); ++p) {
    const uint32_t stored = meta_get32(raw, L.pages, p, 4);
    if (at >= offset && at + len <= offset + stored) {
      *page = p, *page_at = offset;
      return true;
    }
  }
  return false;
}

// The candidates of one shrink step, bytes [at, at + len) removed, in the order tried: (1) the
// bytes removed and the checksums recomputed, nothing else (cheapest when the disagreement
// does not depend on the sizes, e.g. a truncated file); (2) inside one page's stored bytes,
// the page edited (stored size — and raw size when uncompressed — file_size and every CRC
// fixed: format_edit.h); elsewhere past the header, the bytes removed with file_size (and
// metadata_size inside the metadata) moved and the checksums recomputed. So a CRC-protected
// file shrinks past its checksums and sizes to the rule that disagrees.
std::vector<std::vector<uint8_t>> shrink_candidates(const std::vector<uint8_t>& bytes, size_t at, size_t len) {
  constexpr size_t kHeaderBytes = 64;
  std::vector<uint8_t> plain = bytes;
  plain.erase(plain.begin() + long(at), plain.begin() + long(std::min(bytes.size(), at + len)));
  len = bytes.size() - plain.size();
  std::vector<uint8_t> structural = bytes;
  uint32_t page = 0;
  size_t page_at = 0;
  bool done = false;
  if (page_holding(bytes, at, len, &page, &page_at)) {
    const bool uncompressed = Compression(le32_at(&bytes[24])) == Compression::kNone;
    done = edit_stored_page(structural, page, [&](std::vector<uint8_t>& stored) {
      stored.erase(stored.begin() + long(at - page_at), stored.begin() + long(at - page_at + len));
    }, uncompressed);
    if (!done) structural = bytes;
  }
  if (!done && at >= kHeaderBytes) {
    structural = plain;
    const uint64_t file_size = uint64_t(le32_at(&structural[16])) | uint64_t(le32_at(&structural[20])) << 32;
    put_le32_at(&structural[16], uint32_t(file_size - len));
    put_le32_at(&structural[20], uint32_t((file_size - len) >> 32));
    const uint32_t meta_size = le32_at(&structural[36]);
    if (at + len <= kHeaderBytes + meta_size) put_le32_at(&structural[36], uint32_t(meta_size - len));
    done = true;
  }
  fix_checksums(plain);
  if (!done) return {plain};
  fix_checksums(structural);
  if (structural == plain) return {plain};
  return {plain, structural};
}

// Shrinks a reproducer (spec/conform.md §5.4): removes byte ranges — halves, then quarters, ...
// down to single bytes — keeping the first candidate of each removal (shrink_candidates) after
// which vgeo and the decoder still disagree the same way, until no range can go or `max_runs`
// decoder runs are spent.
std::vector<uint8_t> minimize(std::vector<uint8_t> bytes, const std::string& kind,
                              const std::function<std::string(const std::vector<uint8_t>&)>& kind_of, size_t max_runs,
                              size_t* runs) {
  // Compressed metadata first stored uncompressed (one run, kept when the disagreement stays):
  // a page edit rewrites the metadata uncompressed (format_edit.h), which would make every
  // structural candidate larger than the file it shrinks.
  if (bytes.size() >= 64 && le32_at(&bytes[8]) >= 2 && le32_at(&bytes[48]) != 0 && *runs < max_runs) {
    std::vector<uint8_t> plain_meta = bytes;
    if (edit_metadata(plain_meta, [](std::vector<uint8_t>&, const MetaLayout&) {})) {
      ++*runs;
      if (kind_of(plain_meta) == kind) bytes = std::move(plain_meta);
    }
  }
  for (size_t chunk = std::max<size_t>(1, bytes.size() / 2); *runs < max_runs; chunk /= 2) {
    for (size_t at = 0; at < bytes.size() && *runs < max_runs;) {
      bool kept = false;
      for (std::vector<uint8_t>& smaller : shrink_candidates(bytes, at, chunk)) {
        if (*runs >= max_runs) break;
        if (smaller.size() >= bytes.size()) continue;  // (an edit that rewrote the metadata larger)
        ++*runs;
        if (kind_of(smaller) == kind) {
          bytes = std::move(smaller);
          kept = true;
          break;
        }
      }
      if (!kept) at += chunk;
    }
    if (chunk == 1) break;
  }
  return bytes;
}

struct DecoderArgs {
  std::string vectors, out = "conform-decoder-out", junit_path;  // vectors: "" = the default (resolve_vectors_dir)
  std::vector<std::string> command;
  uint32_t mutants = 1000;
  uint64_t seed = 1;
  double timeout_s = 10;
  bool strict_codes = false, quiet = false, minimize = false;
  uint32_t minimize_runs = 500;  // decoder runs per reproducer: a 20 KB file shrinks in ~200
};

struct Tally {
  size_t inputs = 0, verdict = 0, hash = 0, code = 0, protocol = 0;
  std::map<std::string, size_t> mutant_verdicts;  // vgeo's verdicts on the mutants (what they exercised)
  std::map<std::string, std::map<std::string, size_t>> kind_verdicts;  // the same per mutation kind
};

int run_conform_decoder(const DecoderArgs& a) {
  if (a.command.empty())
    fail("CONFORM_USAGE", "vgeo conform decoder", "give the decoder command after --", kExitUsage);
  // The vectors: every line of manifest.txt (`name expected`).
  const std::string vectors = resolve_vectors_dir(a.vectors, "spec/vectors", "manifest.txt");
  std::vector<std::pair<std::string, std::vector<uint8_t>>> inputs;
  std::vector<std::vector<uint8_t>> valid;
  {
    const std::string manifest = vectors + "/manifest.txt";
    std::istringstream f(read_conform_text(manifest, "the vector manifest"));
    std::string line;
    while (std::getline(f, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::string name = line.substr(0, line.find(' '));
      inputs.emplace_back(name, read_bytes(vectors + "/" + name));
      if (line.find(" OK ") != std::string::npos) valid.push_back(inputs.back().second);
    }
  }
  if (valid.empty() && a.mutants > 0)
    fail("CONFORM_IO", vectors + "/manifest.txt", "lists no valid file to mutate", kExitBadInput);
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec) fail("CONFORM_IO", a.out, "cannot create the output folder: " + ec.message(), kExitIo);
  const std::string scratch = a.out + "/input.vgp";

  Tally t;
  JunitSuite suite{"vgeo conform decoder", {}};
  std::string log;
  Rng rng{a.seed};
  // Progress on a terminal (a 10,000-mutant run takes minutes), nothing in CI or when piped.
  std::optional<Progress> progress(std::in_place, "conform decoder", inputs.size() + a.mutants, !a.quiet && progress_wanted());
  const auto started = std::chrono::steady_clock::now();
  auto seconds_since = [](std::chrono::steady_clock::time_point from) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - from).count();
  };
  double case_seconds = 0;  // time of the inputs that have their own testcase
  auto judge = [&](const std::string& name, const std::vector<uint8_t>& bytes, bool always_case, const std::string& mutation) {
    const auto judge_started = std::chrono::steady_clock::now();
    write_file_atomic(scratch, bytes.data(), bytes.size());
    Verdict ours = our_verdict(bytes), theirs = run_decoder(a.command, scratch, a.timeout_s);
    if (!always_case) {
      const std::string verdict = ours.kind == Verdict::kAccept ? "accepted" : ours.value;
      ++t.mutant_verdicts[verdict];
      ++t.kind_verdicts[mutation][verdict];
    }
    ++t.inputs;
    const std::string kind = disagreement(ours, theirs);
    if (kind == "protocol") ++t.protocol;
    else if (kind == "verdict") ++t.verdict;
    else if (kind == "hash") ++t.hash;
    else if (kind == "code") ++t.code;
    JunitCase tc = junit_case("vgeo.conform.decoder", name);
    if (!kind.empty()) {
      const std::string repro = a.out + "/" + name + (name.size() > 4 && name.ends_with(".vgp") ? "" : ".vgp");
      write_file_atomic(repro, bytes.data(), bytes.size());
      std::string line = kind + " " + name + ": vgeo " + ours.text() + ", decoder " + theirs.text() + " (" + repro + ")";
      const bool counts = kind != "code" || a.strict_codes;
      if (a.minimize && counts) {  // (code disagreements are reported, not failures: not shrunk)
        size_t runs = 0;
        const std::vector<uint8_t> small = minimize(bytes, kind, [&](const std::vector<uint8_t>& b) {
          write_file_atomic(scratch, b.data(), b.size());
          return disagreement(our_verdict(b), run_decoder(a.command, scratch, a.timeout_s));
        }, a.minimize_runs, &runs);
        const std::string min_path = repro.substr(0, repro.size() - 4) + ".min.vgp";
        write_file_atomic(min_path, small.data(), small.size());
        line += "; minimized " + std::to_string(bytes.size()) + " -> " + std::to_string(small.size()) + " bytes in " +
                std::to_string(runs) + " runs (" + min_path + ")";
      }
      log += line + "\n";
      if (!a.quiet) std::printf("%s\n", line.c_str());
      tc.failed = counts;
      tc.failure_type = "CONFORM_DECODER_" + std::string(kind == "verdict" ? "VERDICT" : kind == "hash" ? "HASH" : kind == "code" ? "CODE" : "PROTOCOL");
      tc.failure_message = line;
      if (!counts) tc.skipped = true, tc.skipped_message = line;
    }
    if (always_case || !kind.empty()) {
      tc.seconds = seconds_since(judge_started);
      case_seconds += tc.seconds;
      suite.cases.push_back(std::move(tc));
    }
    progress->advance();
  };
  for (const auto& [name, bytes] : inputs) judge(name, bytes, true, "");
  for (uint32_t i = 0; i < a.mutants; ++i) {
    std::string kind;
    std::vector<uint8_t> m = mutate(valid, rng, &kind);
    char name[64];
    std::snprintf(name, sizeof name, "mutant-%06u-%s", i, kind.c_str());
    judge(name, m, false, kind);
  }
  progress.reset();  // its last line, before the summary
  std::filesystem::remove(scratch, ec);
  const double total_seconds = seconds_since(started);
  const size_t hard = t.verdict + t.hash + t.protocol + (a.strict_codes ? t.code : 0);
  JunitCase summary = junit_case("vgeo.conform.decoder", "mutants (seed " + std::to_string(a.seed) + ")");
  if (hard) {
    summary.failed = true;
    summary.failure_type = "CONFORM_DECODER_DISAGREEMENT";
    summary.failure_message = std::to_string(hard) + " disagreement(s) over " + std::to_string(t.inputs) + " inputs";
  }
  // The mutants that have no testcase of their own: the suite's time is the run's.
  summary.seconds = std::max(0.0, total_seconds - case_seconds);
  suite.cases.push_back(summary);
  const std::string summary_line = std::to_string(t.inputs) + " inputs (" + std::to_string(inputs.size()) +
                                   " vectors, " + std::to_string(a.mutants) + " mutants, seed " + std::to_string(a.seed) +
                                   "): " + std::to_string(t.verdict) + " verdict, " + std::to_string(t.hash) + " hash, " +
                                   std::to_string(t.protocol) + " protocol, " + std::to_string(t.code) +
                                   " code disagreements in " + seconds_text(total_seconds) + " s";
  std::string verdicts = "vgeo's verdicts on the mutants:";
  for (const auto& [verdict, n] : t.mutant_verdicts) verdicts += " " + verdict + " " + std::to_string(n);
  for (const auto& [kind, counts] : t.kind_verdicts) {
    verdicts += "\n  " + kind + ":";
    for (const auto& [verdict, n] : counts) verdicts += " " + verdict + " " + std::to_string(n);
  }
  log += summary_line + "\n" + verdicts + "\n";
  write_file_atomic(a.out + "/disagreements.txt", log.data(), log.size());
  if (!a.quiet) std::printf("%s\n%s\n", summary_line.c_str(), verdicts.c_str());
  if (!a.junit_path.empty()) write_junit(a.junit_path, "vgeo conform decoder", {suite});
  return hard ? kExitInvariantViolation : kExitOk;
}

}  // namespace

void add_conform_decoder_command(CLI::App& conform, Context& ctx) {
  auto args = std::make_shared<DecoderArgs>();
  auto* cmd = conform.add_subcommand("decoder", "differential test of another page decoder: -- CMD ARGS... (spec/conform.md §5)");
  cmd->add_option("--vectors", args->vectors, "vector folder with manifest.txt (default spec/vectors, found in the working directory or above the vgeo binary)");
  cmd->add_option("--mutants", args->mutants, "seeded mutants of the valid vectors (default 1000)");
  cmd->add_option("--seed", args->seed, "mutation seed (same seed, same mutants)");
  cmd->add_option("--out", args->out, "folder for reproducers and disagreements.txt (default conform-decoder-out)");
  cmd->add_option("--timeout", args->timeout_s, "seconds per decoder run before it counts as a protocol failure");
  cmd->add_option("--junit", args->junit_path, "write a JUnit XML report (every vector, every disagreeing mutant)");
  cmd->add_flag("--strict-codes", args->strict_codes, "count different error codes as failures (default: reported only)");
  cmd->add_flag("--quiet", args->quiet, "print nothing; rely on the exit code");
  cmd->add_flag("--minimize", args->minimize, "shrink each reproducer while the disagreement stays (NAME.min.vgp)");
  cmd->add_option("--minimize-runs", args->minimize_runs, "decoder runs per reproducer for --minimize (default 500)");
  cmd->add_option("command", args->command, "the decoder: CMD ARGS... (the file is appended)")->expected(-1);
  cmd->callback([args, &ctx] { ctx.exit_code = run_conform_decoder(*args); });

  auto file = std::make_shared<std::string>();
  auto* hash = conform.add_subcommand(
      "hash", "vgeo's decoder behind the protocol: print FILE's decode hash (then memory=HASH) or error[CODE]; "
              "a .vgeodag file is read as VGEODAG1 (its decode hash, spec/format.md §9)");
  hash->add_option("file", *file, "page-format file, or VGEODAG1 file (.vgeodag)")->required();
  hash->callback([file, &ctx] {
    std::vector<uint8_t> bytes;
    try {
      bytes = read_file(*file, kAnyFileSize);
    } catch (const VgeoError& e) {
      std::printf("error[CONFORM_IO]\n");
      std::fflush(stdout);
      std::fprintf(stderr, "error[CONFORM_IO]: %s: cannot read the file (%s: %s)\n", file->c_str(),
                   e.error().code.c_str(), e.error().what.c_str());
      ctx.exit_code = e.error().exit_code;
      return;
    }
    // One reader per file, chosen as `vgeo verify` chooses (asset_file.h): the extension
    // .vgeodag is the VGEODAG1 reader, anything else the page decoder.
    const bool dag = asset_file_kind_for_path(*file) == AssetFileKind::kDagFile;
    Verdict v = dag ? our_dag_verdict(bytes, *file) : our_verdict(bytes, *file);
    std::printf("%s\n", v.text().c_str());
    // The protocol reads the first line only; the memory hash (spec/format.md §9, the
    // manifest's `memory=`) follows for a page file that decodes.
    if (v.kind == Verdict::kAccept && !dag)
      std::printf("memory=%s\n", hash_text(memory_form_hash(bytes.data(), bytes.size(), "<conform>")).c_str());
    std::fflush(stdout);
    // The reason on stderr, as every vgeo error (`error[CODE]: where: what`).
    if (v.kind == Verdict::kReject)
      std::fprintf(stderr, "error[%s]: %s\n", v.value.c_str(), v.reason.c_str());
    ctx.exit_code = v.kind == Verdict::kAccept ? kExitOk : kExitBadInput;
  });
}

}  // namespace vgeo::cli
