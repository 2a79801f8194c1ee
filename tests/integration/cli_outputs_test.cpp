// Every kind of file the `vgeo` tool writes goes through the one atomic writer
// (lib/vgeo/core/file_io.h): when the write fails — here the file-size limit of the process
// (RLIMIT_FSIZE, SIGXFSZ ignored so the write fails with EFBIG) — the command exits 4 with one
// coded line, the previous file at the path is left as it was, and no temporary remains.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/paths.h"
#include "support/run_command.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

std::string contents(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// `vgeo ARGS` with writes above 1 KiB failing (ulimit -f counts 512- or 1024-byte blocks
// depending on the shell; either way far below every output below).
test::CliResult run_cli_with_small_file_limit(const std::string& args) {
  return test::run_command("sh -c \"trap '' XFSZ; ulimit -f 1; exec '" + test::cli_path() + "' " + args + "\"");
}

TEST(CliOutputs, AFailedWriteOfEveryOutputKindIsCodedAndKeepsThePreviousFile) {
  const fs::path dir = fs::temp_directory_path() / ("vgeo_cli_outputs_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "out");
  const std::string mesh = (dir / "mesh.glb").string(), asset = (dir / "mesh.vgp").string();
  ASSERT_EQ(test::run_cli("gen sphere -n 20000 -o '" + mesh + "'").exit_code, 0);
  ASSERT_EQ(test::run_cli("build '" + mesh + "' -o '" + asset + "'").exit_code, 0);
  const std::string scene = (test::source_dir() / "tests" / "scenes" / "spheres.json").string();

  struct Case {
    const char* what;
    std::string output;  // the file the command writes first
    std::string args;
  };
  const fs::path out = dir / "out";
  const Case cases[] = {
      {"mesh export (gen -o .glb)", (out / "m.glb").string(), "gen sphere -n 20000 -o '" + (out / "m.glb").string() + "'"},
      {"mesh export (gen -o .obj)", (out / "m.obj").string(), "gen sphere -n 20000 -o '" + (out / "m.obj").string() + "'"},
      {"page file (build -o .vgp)", (out / "a.vgp").string(), "build '" + mesh + "' -o '" + (out / "a.vgp").string() + "'"},
      {"DAG file (build -o .vgeodag)", (out / "a.vgeodag").string(),
       "build '" + mesh + "' -o '" + (out / "a.vgeodag").string() + "'"},
      {"verify JSON report", (out / "verify.json").string(),
       "verify '" + asset + "' --quiet --views 2 --json '" + (out / "verify.json").string() + "'"},
      {"render PNG", (out / "f.png").string(), "render '" + scene + "' --no-cache -o '" + (out / "f.png").string() + "'"},
      {"render JSON statistics", (out / "r.json").string(),
       "render '" + scene + "' --no-cache --json-file '" + (out / "r.json").string() + "'"},
      {"demo verify report", (out / "verify.json").string(),
       "demo --triangles 20000 --width 16 --height 16 --out '" + out.string() + "'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const std::string previous = "previous contents of the output";
    std::ofstream(c.output, std::ios::binary) << previous;
    const test::CliResult r = run_cli_with_small_file_limit(c.args);
    EXPECT_EQ(r.exit_code, 4) << r.output;
    EXPECT_NE(r.output.find("error[IO_WRITE_FAILED]: " + c.output + ": writing failed"), std::string::npos) << r.output;
    EXPECT_EQ(contents(c.output), previous);
    for (const auto& e : fs::directory_iterator(out))
      EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << "temporary left: " << e.path();
    fs::remove(c.output);
  }
  fs::remove_all(dir);
}

// `vgeo build --report` is written after the asset: a report that cannot be written (its
// folder is missing) is coded too, and the asset already written stays complete.
TEST(CliOutputs, AnUnwritableBuildReportIsCoded) {
  const fs::path dir = fs::temp_directory_path() / ("vgeo_cli_report_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string mesh = (dir / "mesh.glb").string(), asset = (dir / "mesh.vgp").string();
  const std::string report = (dir / "missing" / "report.json").string();
  ASSERT_EQ(test::run_cli("gen sphere -n 2000 -o '" + mesh + "'").exit_code, 0);
  const test::CliResult r = test::run_cli("build '" + mesh + "' -o '" + asset + "' --report '" + report + "'");
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("error[IO_WRITE_FAILED]: " + report + ": creating the temporary file failed"), std::string::npos)
      << r.output;
  EXPECT_EQ(test::run_cli("verify '" + asset + "' --quiet --views 2").exit_code, 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vgeo
