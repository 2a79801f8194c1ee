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

#include <chrono>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <functional>
#include <sstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "conform.h"
#include "junit.h"
#include "vgeo/core/error.h"
#include "vgeo/format/decode_hash.h"
#include "vgeo/format/format.h"
#include "vgeo/format/format_edit.h"
#include "vgeo/core/file_io.h"

namespace vgeo::cli {

namespace {

constexpr size_t kMaxVerdictBytes = 4096;  // a verdict is one short line; more is a protocol error

// A decoder's answer: accepted with a hash, rejected with a code, or no valid answer.
struct Verdict {
  enum Kind { kAccept, kReject, kProtocol } kind = kProtocol;
  std::string value;  // hash (16 hex), code, or what went wrong
  std::string text() const {
    return kind == kAccept ? value : kind == kReject ? "error[" + value + "]" : "protocol: " + value;
  }
};

std::string hash_text(uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

Verdict our_verdict(const std::vector<uint8_t>& bytes) {
  Verdict v;
  try {
    v.value = hash_text(decode_hash(decode_format(bytes.data(), bytes.size(), "<conform>")));
    v.kind = Verdict::kAccept;
  } catch (const VgeoError& e) {
    v.kind = Verdict::kReject;
    v.value = e.error().code;
  } catch (const std::bad_alloc&) {
    v.kind = Verdict::kReject;
    v.value = "OUT_OF_MEMORY";
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

// Runs CMD ARGS FILE with stdout captured (stderr discarded), killed after `timeout_s`.
Verdict run_decoder(const std::vector<std::string>& command, const std::string& file, double timeout_s) {
  int fds[2];
  if (pipe(fds) != 0) return {Verdict::kProtocol, "pipe failed"};
  pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]), close(fds[1]);
    return {Verdict::kProtocol, "fork failed"};
  }
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    int null_fd = open("/dev/null", O_WRONLY);
    if (null_fd >= 0) dup2(null_fd, STDERR_FILENO);
    close(fds[0]), close(fds[1]);
    std::vector<char*> argv;
    for (const std::string& a : command) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(const_cast<char*>(file.c_str()));
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  std::string out;
  bool timed_out = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, int(left)) <= 0) continue;
    char buf[1024];
    ssize_t n = read(fds[0], buf, sizeof buf);
    if (n <= 0) break;
    if (out.size() < kMaxVerdictBytes) out.append(buf, size_t(n));
  }
  close(fds[0]);
  if (timed_out) kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  if (timed_out) return {Verdict::kProtocol, "no verdict within the timeout"};
  if (WIFSIGNALED(status)) return {Verdict::kProtocol, "killed by signal " + std::to_string(WTERMSIG(status))};
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127 && out.empty()) return {Verdict::kProtocol, "cannot run the command"};
  return parse_verdict(out);
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

// Byte-level kinds (0-5) see mostly the CRC and length checks; the structure-aware kinds (6-8)
// edit a metadata field, a raw page field, or a raw page's length, then fix every size and
// checksum (lib/vgeo/format/format_edit.h), so the decoder's deeper rules are reached.
const char* const kMutationKinds[] = {"truncate", "bitflip", "byte", "splice", "duplicate", "delete",
                                      "field", "page-field", "page-length"};
constexpr size_t kByteMutationKinds = 6, kMutationKindCount = 9;

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

std::vector<uint8_t> mutate(const std::vector<std::vector<uint8_t>>& sources, Rng& rng, std::string* kind) {
  const std::vector<uint8_t>& src = sources[rng.below(sources.size())];
  std::vector<uint8_t> m = src;
  const size_t k = rng.below(kMutationKindCount);
  *kind = kMutationKinds[k];
  if (m.empty()) return m;
  if (k >= kByteMutationKinds) {
    // A source this module cannot edit (not one of ours) falls back to a bit flip.
    const bool ok = k == 6 ? mutate_metadata_field(m, rng) : mutate_page(m, rng, k == 8);
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

// Shrinks a reproducer (spec/conform.md §5.4): removes byte ranges — halves, then quarters, ...
// down to single bytes — keeping each removal after which vgeo and the decoder still disagree
// the same way, until no range can go or `max_runs` decoder runs are spent.
std::vector<uint8_t> minimize(std::vector<uint8_t> bytes, const std::string& kind,
                              const std::function<std::string(const std::vector<uint8_t>&)>& kind_of, size_t max_runs,
                              size_t* runs) {
  for (size_t chunk = std::max<size_t>(1, bytes.size() / 2); *runs < max_runs; chunk /= 2) {
    for (size_t at = 0; at < bytes.size() && *runs < max_runs;) {
      std::vector<uint8_t> smaller = bytes;
      smaller.erase(smaller.begin() + long(at), smaller.begin() + long(std::min(bytes.size(), at + chunk)));
      ++*runs;
      if (kind_of(smaller) == kind) bytes = std::move(smaller);
      else at += chunk;
    }
    if (chunk == 1) break;
  }
  return bytes;
}

struct DecoderArgs {
  std::string vectors = "spec/vectors", out = "conform-decoder-out", junit_path;
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
  std::vector<std::pair<std::string, std::vector<uint8_t>>> inputs;
  std::vector<std::vector<uint8_t>> valid;
  {
    const std::string manifest = a.vectors + "/manifest.txt";
    std::istringstream f(read_conform_text(manifest, "the vector manifest"));
    std::string line;
    while (std::getline(f, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::string name = line.substr(0, line.find(' '));
      inputs.emplace_back(name, read_bytes(a.vectors + "/" + name));
      if (line.find(" OK ") != std::string::npos) valid.push_back(inputs.back().second);
    }
  }
  if (valid.empty() && a.mutants > 0)
    fail("CONFORM_IO", a.vectors + "/manifest.txt", "lists no valid file to mutate", kExitBadInput);
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec) fail("CONFORM_IO", a.out, "cannot create the output folder: " + ec.message(), kExitIo);
  const std::string scratch = a.out + "/input.vgp";

  Tally t;
  JunitSuite suite{"vgeo conform decoder", {}};
  std::string log;
  Rng rng{a.seed};
  auto judge = [&](const std::string& name, const std::vector<uint8_t>& bytes, bool always_case, const std::string& mutation) {
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
    if (always_case || !kind.empty()) suite.cases.push_back(std::move(tc));
  };
  for (const auto& [name, bytes] : inputs) judge(name, bytes, true, "");
  for (uint32_t i = 0; i < a.mutants; ++i) {
    std::string kind;
    std::vector<uint8_t> m = mutate(valid, rng, &kind);
    char name[64];
    std::snprintf(name, sizeof name, "mutant-%06u-%s", i, kind.c_str());
    judge(name, m, false, kind);
  }
  std::filesystem::remove(scratch, ec);
  const size_t hard = t.verdict + t.hash + t.protocol + (a.strict_codes ? t.code : 0);
  JunitCase summary = junit_case("vgeo.conform.decoder", "mutants (seed " + std::to_string(a.seed) + ")");
  if (hard) {
    summary.failed = true;
    summary.failure_type = "CONFORM_DECODER_DISAGREEMENT";
    summary.failure_message = std::to_string(hard) + " disagreement(s) over " + std::to_string(t.inputs) + " inputs";
  }
  suite.cases.push_back(summary);
  const std::string summary_line = std::to_string(t.inputs) + " inputs (" + std::to_string(inputs.size()) +
                                   " vectors, " + std::to_string(a.mutants) + " mutants, seed " + std::to_string(a.seed) +
                                   "): " + std::to_string(t.verdict) + " verdict, " + std::to_string(t.hash) + " hash, " +
                                   std::to_string(t.protocol) + " protocol, " + std::to_string(t.code) +
                                   " code disagreements";
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
  cmd->add_option("--vectors", args->vectors, "vector folder with manifest.txt (default spec/vectors)");
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
      "hash", "vgeo's decoder behind the protocol: print FILE's decode hash (then memory=HASH) or error[CODE]");
  hash->add_option("file", *file, "page-format file")->required();
  hash->callback([file, &ctx] {
    std::vector<uint8_t> bytes;
    try {
      bytes = read_file(*file, kAnyFileSize);
    } catch (const VgeoError& e) {
      std::printf("error[CONFORM_IO]\n");
      ctx.exit_code = e.error().exit_code;
      return;
    }
    Verdict v = our_verdict(bytes);
    std::printf("%s\n", v.text().c_str());
    // The protocol reads the first line only; the memory hash (spec/format.md §9, the
    // manifest's `memory=`) follows for a file that decodes.
    if (v.kind == Verdict::kAccept)
      std::printf("memory=%s\n", hash_text(memory_form_hash(bytes.data(), bytes.size(), "<conform>")).c_str());
    ctx.exit_code = v.kind == Verdict::kAccept ? kExitOk : kExitBadInput;
  });
}

}  // namespace vgeo::cli
