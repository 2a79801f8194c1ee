// `vgeo conform decoder -- CMD` (spec/conform.md §5): vgeo's own decoder behind the protocol
// agrees with itself on every vector and on seeded mutants; a deliberately broken decoder
// (tests/conform/broken_decoder.sh) is caught — verdict and hash disagreements fail the run, code
// disagreements are reported apart — with reproducers that replay to the same verdict.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

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
  EXPECT_NE(r.output.find("  page-field: FORMAT_NON_CANONICAL 1 FORMAT_OUT_OF_RANGE 4"), std::string::npos) << r.output;
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
  EXPECT_NE(r.output.find("hash v1_valid_grid_uv_lz4.vgp: vgeo 305dd628287a70b4, decoder 305dd628287a70b5"),
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

}  // namespace
