// `vgeo conform decoder -- CMD` (spec/conform.md §5): vgeo's own decoder behind the protocol
// agrees with itself on every vector and on seeded mutants; a deliberately broken decoder
// (tests/conform/broken_decoder.sh) is caught — verdict and hash disagreements fail the run, code
// disagreements are reported apart — with reproducers that replay to the same verdict.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <vector>

#include "conform/junit_check.h"
#include "support/paths.h"
#include "support/run_command.h"

namespace fs = std::filesystem;
using vgeo::test::run_cli;

namespace {

// 40 mutants (+ the 21 version 1 vectors): a few seconds; `--mutants 10000` is the on-demand run.
constexpr int kTestMutants = 40;

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("vgeo_conform_decoder_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
};

std::string all_vectors() { return (vgeo::test::source_dir() / "spec" / "vectors").string(); }

// The protocol tests run over the version 1 vectors (21 files, both verdict kinds) so that each
// stays a few seconds; every vector's verdict is checked in-process by FormatVectors.*.
std::string v1_vectors(const TempDir& tmp) {
  const fs::path dir = tmp.path / "v1_vectors";
  fs::create_directories(dir);
  std::ifstream in(fs::path(all_vectors()) / "manifest.txt");
  std::ofstream out(dir / "manifest.txt");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("v1_", 0) != 0) continue;
    const std::string name = line.substr(0, line.find(' '));
    fs::copy_file(fs::path(all_vectors()) / name, dir / name);
    out << line << "\n";
  }
  return dir.string();
}

TEST(ConformDecoder, OwnDecoderAgreesEverywhere) {
  TempDir tmp;
  const std::string vectors = v1_vectors(tmp);
  const std::string xml = (tmp.path / "own.xml").string();
  auto r = run_cli("conform decoder --vectors '" + vectors + "' --mutants " + std::to_string(kTestMutants) +
                   " --seed 3 --out '" + (tmp.path / "own").string() + "' --junit '" + xml + "' -- '" +
                   vgeo::test::cli_path() + "' conform hash");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("0 verdict, 0 hash, 0 protocol, 0 code disagreements"), std::string::npos) << r.output;
  // Structure-aware mutants keep the checksums valid and reach the rules behind them.
  EXPECT_NE(r.output.find("  page-field: FORMAT_OUT_OF_RANGE 4 FORMAT_TRUNCATED 1"), std::string::npos) << r.output;
  // ... and the compressed-stream mutants reach the decompressors.
  EXPECT_NE(r.output.find("  stream: FORMAT_DECOMPRESS 1"), std::string::npos) << r.output;
  std::string cases = vgeo::test::checked_junit(xml);
  EXPECT_NE(cases.find("vgeo.conform.decoder.v1_valid_sphere_zstd.vgp: passed"), std::string::npos) << cases;
  EXPECT_EQ(cases.find("failed"), std::string::npos) << cases;
}

TEST(ConformDecoder, BrokenDecoderIsCaughtWithReproducers) {
  TempDir tmp;
  const std::string vectors = v1_vectors(tmp);
  const fs::path out = tmp.path / "broken";
  const std::string xml = (tmp.path / "broken.xml").string();
  const std::string broken = (vgeo::test::source_dir() / "tests" / "conform" / "broken_decoder.sh").string();
  auto r = run_cli("conform decoder --vectors '" + vectors + "' --mutants " + std::to_string(kTestMutants) +
                   " --seed 3 --out '" + out.string() + "' --junit '" + xml + "' -- sh '" + broken + "' '" +
                   vgeo::test::cli_path() + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  // The planted faults on the vectors themselves.
  EXPECT_NE(r.output.find("verdict v1_truncated.vgp: vgeo error[FORMAT_TRUNCATED], decoder 0123456789abcdef"),
            std::string::npos) << r.output;
  EXPECT_NE(r.output.find("code v1_header_checksum.vgp: vgeo error[FORMAT_CHECKSUM], decoder error[BAD_CRC]"),
            std::string::npos) << r.output;
  EXPECT_NE(r.output.find("hash v1_valid_grid_uv_lz4.vgp: vgeo 5fe86c6d7208c923, decoder 5fe86c6d7208c922"),
            std::string::npos) << r.output;
  std::string cases = vgeo::test::checked_junit(xml);
  EXPECT_NE(cases.find("vgeo.conform.decoder.v1_valid_grid_uv_lz4.vgp: failed CONFORM_DECODER_HASH"), std::string::npos) << cases;
  EXPECT_NE(cases.find("vgeo.conform.decoder.v1_truncated.vgp: failed CONFORM_DECODER_VERDICT"), std::string::npos) << cases;
  EXPECT_NE(cases.find("vgeo.conform.decoder.v1_header_checksum.vgp: skipped"), std::string::npos) << cases;
  EXPECT_NE(cases.find("failed CONFORM_DECODER_DISAGREEMENT"), std::string::npos) << cases;
  // Reproducers replay: our decoder still rejects the saved truncated file the same way.
  ASSERT_TRUE(fs::exists(out / "v1_truncated.vgp"));
  auto replay = run_cli("conform hash '" + (out / "v1_truncated.vgp").string() + "'");
  EXPECT_NE(replay.output.find("error[FORMAT_TRUNCATED]"), std::string::npos) << replay.output;
  std::ifstream log(out / "disagreements.txt");
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_NE(text.str().find("mutant-"), std::string::npos) << "no mutant disagreement among " << kTestMutants << "\n" << text.str();
  // --strict-codes turns the code disagreements into failures too (on a two-vector folder).
  const fs::path small = tmp.path / "small";
  fs::create_directories(small);
  for (const char* name : {"v1_header_checksum.vgp", "v1_valid_sphere_zstd.vgp"})
    fs::copy_file(fs::path(vectors) / name, small / name);
  std::ofstream(small / "manifest.txt") << "v1_header_checksum.vgp FORMAT_CHECKSUM\nv1_valid_sphere_zstd.vgp OK 6a5afe8c33593de5\n";
  const std::string small_run = "conform decoder --vectors '" + small.string() + "' --mutants 0 --quiet --out '" +
                                (tmp.path / "strict").string() + "' --junit '" + xml + "' -- sh '" + broken + "' '" +
                                vgeo::test::cli_path() + "'";
  EXPECT_EQ(run_cli(small_run).exit_code, 0);  // a code disagreement alone does not fail by default
  auto strict = run_cli("conform decoder --strict-codes" + small_run.substr(std::string("conform decoder").size()));
  EXPECT_EQ(strict.exit_code, 1) << strict.output;
  cases = vgeo::test::checked_junit(xml);
  EXPECT_NE(cases.find("vgeo.conform.decoder.v1_header_checksum.vgp: failed CONFORM_DECODER_CODE"), std::string::npos) << cases;
}

// --minimize shrinks a reproducer while the disagreement stays: the broken decoder accepts
// every truncated file, so halving v1_truncated.vgp keeps the verdict disagreement. Eight
// decoder runs keep the test cheap (1167 bytes -> 146).
TEST(ConformDecoder, MinimizeShrinksAReproducer) {
  TempDir tmp;
  const fs::path dir = tmp.path / "one";
  fs::create_directories(dir);
  fs::copy_file(fs::path(all_vectors()) / "v1_truncated.vgp", dir / "v1_truncated.vgp");
  std::ofstream(dir / "manifest.txt") << "v1_truncated.vgp FORMAT_TRUNCATED\n";
  const fs::path out = tmp.path / "min";
  const std::string broken = (vgeo::test::source_dir() / "tests" / "conform" / "broken_decoder.sh").string();
  auto r = run_cli("conform decoder --vectors '" + dir.string() + "' --mutants 0 --minimize --minimize-runs 8 --out '" +
                   out.string() + "' -- sh '" + broken + "' '" + vgeo::test::cli_path() + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const auto original = fs::file_size(dir / "v1_truncated.vgp");
  ASSERT_TRUE(fs::exists(out / "v1_truncated.min.vgp")) << r.output;
  const auto minimized = fs::file_size(out / "v1_truncated.min.vgp");
  EXPECT_LT(minimized, original / 4) << r.output;
  EXPECT_NE(r.output.find("minimized " + std::to_string(original) + " -> " + std::to_string(minimized) + " bytes in 8 runs"),
            std::string::npos) << r.output;
  // The minimized file still disagrees: vgeo rejects it as truncated.
  auto replay = run_cli("conform hash '" + (out / "v1_truncated.min.vgp").string() + "'");
  EXPECT_NE(replay.output.find("error[FORMAT_TRUNCATED]"), std::string::npos) << replay.output;
}

// The `stream` mutants edit compressed streams (lz4 offsets, lengths, tokens; zstd frame
// bytes) and fix every size and CRC, so they reach the decompressors: a decoder that trusts
// its decompressor (tests/conform/lenient_decompress_decoder.sh accepts every FORMAT_DECOMPRESS
// file, as vgeo accepted an lz4 match offset of 0) is caught on mutants, not only on vectors.
// --minimize then shrinks the CRC-protected reproducer: each step fixes sizes and CRCs.
TEST(ConformDecoder, StreamMutantsReachTheDecompressors) {
  TempDir tmp;
  const std::string vectors = v1_vectors(tmp);
  const std::string lenient = (vgeo::test::source_dir() / "tests" / "conform" / "lenient_decompress_decoder.sh").string();
  // Only the mutants (--vectors of the valid v1 files) so that a disagreement is a mutant's.
  const fs::path valid = tmp.path / "valid";
  fs::create_directories(valid);
  {
    std::ifstream in(fs::path(vectors) / "manifest.txt");
    std::ofstream out(valid / "manifest.txt");
    for (std::string line; std::getline(in, line);) {
      if (line.find(" OK ") == std::string::npos) continue;
      const std::string name = line.substr(0, line.find(' '));
      fs::copy_file(fs::path(vectors) / name, valid / name);
      out << line << "\n";
    }
  }
  auto r = run_cli("conform decoder --vectors '" + valid.string() + "' --mutants 200 --seed 7 --out '" +
                   (tmp.path / "lenient").string() + "' -- sh '" + lenient + "' '" + vgeo::test::cli_path() + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const size_t stream = r.output.find("\n  stream:");
  ASSERT_NE(stream, std::string::npos) << r.output;
  const std::string stream_line = r.output.substr(stream + 1, r.output.find('\n', stream + 1) - stream - 1);
  EXPECT_NE(stream_line.find("FORMAT_DECOMPRESS"), std::string::npos) << stream_line;
  EXPECT_NE(r.output.find("-stream: vgeo error[FORMAT_DECOMPRESS], decoder 0123456789abcdef"), std::string::npos) << r.output;

  // The lz4 offset-0 vector, minimized against the lenient decoder: it shrinks (every step keeps
  // the CRCs valid), and the result still is an lz4 stream vgeo rejects.
  const fs::path one = tmp.path / "one";
  fs::create_directories(one);
  fs::copy_file(fs::path(all_vectors()) / "lz4_match_offset_zero.vgp", one / "lz4_match_offset_zero.vgp");
  std::ofstream(one / "manifest.txt") << "lz4_match_offset_zero.vgp FORMAT_DECOMPRESS\n";
  const fs::path out = tmp.path / "min";
  auto m = run_cli("conform decoder --vectors '" + one.string() + "' --mutants 0 --minimize --minimize-runs 60 --out '" +
                   out.string() + "' -- sh '" + lenient + "' '" + vgeo::test::cli_path() + "'");
  EXPECT_EQ(m.exit_code, 1) << m.output;
  ASSERT_TRUE(fs::exists(out / "lz4_match_offset_zero.min.vgp")) << m.output;
  const auto original = fs::file_size(one / "lz4_match_offset_zero.vgp");
  const auto minimized = fs::file_size(out / "lz4_match_offset_zero.min.vgp");
  EXPECT_LT(minimized, original * 3 / 4) << m.output;
  auto replay = run_cli("conform hash '" + (out / "lz4_match_offset_zero.min.vgp").string() + "'");
  EXPECT_NE(replay.output.find("error[FORMAT_DECOMPRESS]"), std::string::npos) << replay.output;
}

// A protocol failure shows the tail of the decoder's stderr (a crash message, a usage error).
TEST(ConformDecoder, ProtocolFailureShowsTheDecodersStderr) {
  TempDir tmp;
  const fs::path dir = tmp.path / "one";
  fs::create_directories(dir);
  fs::copy_file(fs::path(all_vectors()) / "v1_truncated.vgp", dir / "v1_truncated.vgp");
  std::ofstream(dir / "manifest.txt") << "v1_truncated.vgp FORMAT_TRUNCATED\n";
  auto r = run_cli("conform decoder --vectors '" + dir.string() + "' --mutants 0 --out '" + (tmp.path / "out").string() +
                   "' -- sh -c 'echo first line >&2; echo decoder exploded on \"$0\" >&2; exit 3'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("protocol: first line is neither 16 hex digits nor error[CODE]: ''; stderr: first line | decoder exploded on"),
            std::string::npos) << r.output;
}

// `conform hash` gives the reason of a rejection on stderr, as every vgeo error does.
TEST(ConformDecoder, HashGivesTheReasonOnStderr) {
  // (stderr alone: run_command merges stderr into stdout after the subshell.)
  auto r = vgeo::test::run_command("( '" + vgeo::test::cli_path() + "' conform hash '" +
                                   (fs::path(all_vectors()) / "lz4_match_offset_zero.vgp").string() + "' 2>&1 >/dev/null )");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("error[FORMAT_DECOMPRESS]: "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("lz4 match offset 0"), std::string::npos) << r.output;
}

// JUnit times are measured: the suite of a real run takes more than 0 s.
TEST(ConformDecoder, JunitRecordsRealTimes) {
  TempDir tmp;
  const std::string vectors = v1_vectors(tmp);
  const std::string xml = (tmp.path / "t.xml").string();
  auto r = run_cli("conform decoder --vectors '" + vectors + "' --mutants 5 --quiet --out '" + (tmp.path / "o").string() +
                   "' --junit '" + xml + "' -- '" + vgeo::test::cli_path() + "' conform hash");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(xml);
  std::stringstream text;
  text << in.rdbuf();
  const std::string x = text.str();
  const size_t suite = x.find("<testsuite ");
  ASSERT_NE(suite, std::string::npos) << x;
  const size_t t = x.find("time=\"", suite);
  ASSERT_NE(t, std::string::npos) << x;
  EXPECT_GT(std::stod(x.substr(t + 6)), 0.0) << x.substr(suite, 200);
  // Each vector's testcase has its own time (it ran a decoder process: printed as >= 0.001 s).
  const std::string named = "name=\"v1_valid_sphere_zstd.vgp\" time=\"";
  const size_t case_at = x.find(named);
  ASSERT_NE(case_at, std::string::npos) << x;
  EXPECT_GT(std::stod(x.substr(case_at + named.size())), 0.0) << x.substr(case_at, 80);
}

// Without --vectors the vectors are found above the binary, from any working directory; a
// binary outside the repository says which flag to give.
TEST(ConformDecoder, DefaultVectorsFromAnyDirectory) {
  TempDir tmp;
  auto r = vgeo::test::run_command("cd '" + tmp.path.string() + "' && '" + vgeo::test::cli_path() +
                                   "' conform decoder --mutants 0 --quiet --out out -- '" + vgeo::test::cli_path() +
                                   "' conform hash");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const fs::path copy = tmp.path / "bin" / "vgeo";
  fs::create_directories(copy.parent_path());
  fs::copy_file(vgeo::test::cli_path(), copy);
  auto lost = vgeo::test::run_command("cd '" + tmp.path.string() + "' && '" + copy.string() +
                                      "' conform decoder --mutants 0 -- true");
  EXPECT_EQ(lost.exit_code, 2) << lost.output;
  EXPECT_NE(lost.output.find("error[CONFORM_USAGE]: --vectors: no spec/vectors/manifest.txt"), std::string::npos) << lost.output;
}

TEST(ConformDecoder, ProtocolFailuresAndUsage) {
  TempDir tmp;
  const std::string vectors = v1_vectors(tmp);
  auto none = run_cli("conform decoder --vectors '" + vectors + "' --mutants 0");
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_NE(none.output.find("error[CONFORM_USAGE]"), std::string::npos) << none.output;
  // A decoder that prints nothing useful is a protocol failure on every input.
  auto silent = run_cli("conform decoder --vectors '" + vectors + "' --mutants 0 --quiet --out '" +
                        (tmp.path / "silent").string() + "' -- echo hello");
  EXPECT_EQ(silent.exit_code, 1) << silent.output;
}

// `vgeo conform hash` prints the verdict line, then for a valid file its memory hash: both as
// the manifest has them (spec/format.md §9), on every valid version 1 vector.
TEST(ConformDecoder, HashPrintsTheDecodeThenTheMemoryHash) {
  std::ifstream in(fs::path(all_vectors()) / "manifest.txt");
  std::string line;
  int valid = 0;
  while (std::getline(in, line)) {
    if (line.rfind("v1_", 0) != 0 || line.find(" OK ") == std::string::npos) continue;
    std::istringstream words(line);
    std::string name, ok, decode, memory;
    words >> name >> ok >> decode >> memory;
    auto r = run_cli("conform hash '" + (fs::path(all_vectors()) / name).string() + "'");
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.output;
    EXPECT_EQ(r.output, decode + "\n" + memory + "\n") << name;
    ++valid;
  }
  EXPECT_GT(valid, 0);
}

// `vgeo conform hash FILE.vgeodag` prints the VGEODAG1 decode hash (spec/format.md §9: the
// arrays as stored, not rotated) or the DAGFILE_* code: exactly the lines of
// spec/vectors/dag/manifest.txt, for every vector. Then the check order of spec/dag.md §7: the
// scene-table bound (step 2) comes before the instances' mesh index (step 4), which comes
// before anything in a mesh (step 5).
TEST(ConformDecoder, HashReadsVgeodagAsTheDagManifestSays) {
  const fs::path dir = fs::path(all_vectors()) / "dag";
  std::ifstream in(dir / "manifest.txt");
  ASSERT_TRUE(in);
  int checked = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    std::string name, expected, hash;
    words >> name >> expected >> hash;
    auto r = vgeo::test::run_command("( '" + vgeo::test::cli_path() + "' conform hash '" + (dir / name).string() + "' 2>/dev/null )");
    EXPECT_EQ(r.output, (expected == "OK" ? hash : "error[" + expected + "]") + "\n") << name;
    EXPECT_EQ(r.exit_code, expected == "OK" ? 0 : 3) << name;
    ++checked;
  }
  EXPECT_GE(checked, 16);

  // valid_leaf.vgeodag: header 24 bytes (magic, version, mesh/material/instance counts at 12/16/20).
  std::ifstream leaf_in(dir / "valid_leaf.vgeodag", std::ios::binary);
  const std::vector<uint8_t> leaf{std::istreambuf_iterator<char>(leaf_in), std::istreambuf_iterator<char>()};
  ASSERT_GT(leaf.size(), 100u);
  auto put32 = [](std::vector<uint8_t>& f, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) f[at + k] = uint8_t(v >> (8 * k));
  };
  auto get32 = [](const std::vector<uint8_t>& f, size_t at) {
    return uint32_t(f[at]) | uint32_t(f[at + 1]) << 8 | uint32_t(f[at + 2]) << 16 | uint32_t(f[at + 3]) << 24;
  };
  ASSERT_EQ(get32(leaf, 12), 1u);  // one mesh
  ASSERT_GE(get32(leaf, 20), 1u);  // an instance
  size_t instance0 = 24;
  for (uint32_t m = 0; m < get32(leaf, 16); ++m) instance0 += 4 + get32(leaf, instance0) + 16;
  TempDir tmp;
  auto code_of = [&](const std::vector<uint8_t>& f, const std::string& name) {
    const fs::path p = tmp.path / name;
    std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(f.data()), std::streamsize(f.size()));
    return vgeo::test::run_command("( '" + vgeo::test::cli_path() + "' conform hash '" + p.string() + "' 2>/dev/null )").output;
  };
  std::vector<uint8_t> f = leaf;
  put32(f, instance0, 7);  // instance 0 names mesh 7 of 1
  EXPECT_EQ(code_of(f, "instance.vgeodag"), "error[DAGFILE_INDEX_OUT_OF_RANGE]\n");
  std::vector<uint8_t> g = f;
  put32(g, 12, 1u << 28);  // and a mesh count no file of this size can hold: the bound wins
  EXPECT_EQ(code_of(g, "bound.vgeodag"), "error[DAGFILE_TRUNCATED]\n");
  std::vector<uint8_t> h = f;
  put32(h, instance0 + 68, get32(h, instance0 + 68) | 4u);  // and mesh 0's flags unknown (one instance)
  ASSERT_EQ(get32(leaf, 20), 1u);
  EXPECT_EQ(code_of(h, "mesh.vgeodag"), "error[DAGFILE_INDEX_OUT_OF_RANGE]\n");
}

}  // namespace
