// Acceptance over the real CGAL corpus (tools/fetch-data): EVERY mesh of data/cgal/meshes
// (.off, .ply, .stl) imports, builds with both simplifiers and passes every invariant of
// spec/invariants.md (verify_dag, all checks, kAcceptanceViews views); the meshopt DAGs also
// survive the page format (encode_format → decode_format → verify_dag on quantized positions).
// Plus the CLI path `vgeo build … && vgeo verify …` on a few meshes.
//
// Under ASan+UBSan (kSanitizerBuild) the corpus is limited to meshes of at most
// kSanitizerMaxTriangles input triangles (kSanitizerMaxTrianglesOpenMesh for that backend): the full corpus (~0.8M triangles, two backends)
// takes minutes in release and would blow the 30-minute CI budget under the sanitizers.
// The release build always runs every mesh (docs/acceptance/issue3.md).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <unistd.h>
#include <cstdlib>

#include "acceptance.h"
#include "support/paths.h"
#include "vgeo/core/thread_pool.h"
#include "vgeo/mesh/import.h"

namespace fs = std::filesystem;

namespace vgeo::test {
namespace {

// Sanitizer-build cap on input triangles (see the file comment); 20k keeps ~110 of the 142
// meshes that have triangles, including the open, multi-component and degenerate ones.
constexpr size_t kSanitizerMaxTriangles = 20'000;
// The OpenMesh backend's sanitized builds are mostly OpenMesh's own decimator allocating
// (ASan's allocation stacks were 25% of a profile): 8k keeps 121 of the 137 meshes the 20k cap
// keeps and about 38% of their OpenMesh build time (the whole openmesh run took 166 s of the
// sanitized CI run with 20k).
constexpr size_t kSanitizerMaxTrianglesOpenMesh = 8'000;

// b9.ply is a 22,300-point cloud (`element face 0`): genuinely no triangles.
const std::set<std::string> kExpectedEmpty = {"b9.ply"};

// Debian's libcgal-demo ships 138 .off plus 3 .ply and 2 .stl (tests/mesh/import_corpus_test.cpp).
constexpr size_t kMinCorpusFiles = 143;

std::vector<fs::path> corpus_files() {
  std::vector<fs::path> out;
  fs::path dir = data_dir() / "cgal" / "meshes";
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (e.is_regular_file() && (ext == ".off" || ext == ".ply" || ext == ".stl")) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

struct CorpusMesh {
  std::string name;  // file name
  Scene scene;       // one mesh (OpenMesh formats)
};

struct CorpusLoad {
  std::vector<CorpusMesh> meshes;  // imported, within the cap, largest first (load balance)
  std::vector<std::string> failures;
  size_t files = 0, skipped_by_cap = 0, expected_empty = 0;
};

CorpusLoad load_corpus(size_t max_triangles) {
  CorpusLoad load;
  for (const fs::path& f : corpus_files()) {
    ++load.files;
    std::string name = f.filename().string();
    try {
      ImportResult r = import_scene(f.string());
      if (kExpectedEmpty.count(name)) {
        load.failures.push_back(name + ": expected MESH_EMPTY, imported");
        continue;
      }
      if (r.scene.meshes.size() != 1) {
        load.failures.push_back(name + ": " + std::to_string(r.scene.meshes.size()) + " meshes, expected 1");
        continue;
      }
      if (r.scene.meshes[0].triangle_count() > max_triangles) {
        ++load.skipped_by_cap;
        continue;
      }
      load.meshes.push_back({name, std::move(r.scene)});
    } catch (const VgeoError& e) {
      if (kExpectedEmpty.count(name) && e.error().code == "MESH_EMPTY") {
        ++load.expected_empty;
        continue;
      }
      load.failures.push_back(name + ": import threw " + e.what());
    }
  }
  std::stable_sort(load.meshes.begin(), load.meshes.end(), [](const CorpusMesh& a, const CorpusMesh& b) {
    return a.scene.meshes[0].triangle_count() > b.scene.meshes[0].triangle_count();
  });
  return load;
}

size_t corpus_cap(Simplifier simplifier) {
  if (!kSanitizerBuild) return SIZE_MAX;
  return simplifier == Simplifier::kOpenMesh ? kSanitizerMaxTrianglesOpenMesh : kSanitizerMaxTriangles;
}

// Runs every loaded mesh through run_acceptance in parallel; results in load order.
std::vector<AcceptanceRun> run_corpus(const CorpusLoad& load, Simplifier simplifier, bool roundtrip) {
  std::vector<AcceptanceRun> runs(load.meshes.size());
  ThreadPool pool;
  pool.parallel_for(load.meshes.size(), [&](size_t i) {
    const CorpusMesh& m = load.meshes[i];
    runs[i] = run_acceptance(m.name, m.scene.meshes[0], m.scene.materials, simplifier, roundtrip);
  });
  return runs;
}

// Loads the corpus (within the sanitizer cap), runs it, reports every failing run.
void check_corpus(Simplifier simplifier, bool roundtrip) {
  CorpusLoad load = load_corpus(corpus_cap(simplifier));
  ASSERT_GE(load.files, kMinCorpusFiles) << "CGAL corpus missing or incomplete: run tools/fetch-data";
  EXPECT_EQ(load.expected_empty, kExpectedEmpty.size());
  for (const std::string& f : load.failures) ADD_FAILURE() << f;
  if (kSanitizerBuild)
    std::printf("sanitizer build: %zu meshes above %zu triangles not run (release runs all)\n",
                load.skipped_by_cap, corpus_cap(simplifier));
  else
    EXPECT_EQ(load.skipped_by_cap, 0u);

  auto t0 = std::chrono::steady_clock::now();
  std::vector<AcceptanceRun> runs = run_corpus(load, simplifier, roundtrip);
  size_t failed = 0;
  uint64_t triangles = 0;
  for (const AcceptanceRun& r : runs) {
    triangles += r.build.input_triangles;
    EXPECT_EQ(r.roundtrip_ran, roundtrip) << r.mesh;
    if (!r.ok()) {
      ++failed;
      ADD_FAILURE() << r.failure();
    }
  }
  std::printf("%s: %zu meshes, %llu input triangles, %zu failed, %.1f s\n", simplifier_name(simplifier),
              runs.size(), (unsigned long long)triangles, failed, seconds_since(t0));
}

class Corpus : public ::testing::TestWithParam<Simplifier> {};

// Property: for every CGAL mesh with triangles and this backend, build_dag succeeds and
// every invariant of spec/invariants.md holds (verify_dag, all checks).
TEST_P(Corpus, EveryMeshBuildsAndVerifies) { check_corpus(GetParam(), /*roundtrip=*/false); }

// Property: the DAG decoded from the page format (positions, normals, UVs quantized; metadata
// bit-identical, spec/format.md §Decoded scene) still passes every invariant. meshopt DAGs
// only: the format does not depend on the backend and the openmesh corpus build is the
// slowest part of the suite (the generated-mesh round trip covers both backends).
TEST(CorpusPageFormat, DecodedDagOfEveryMeshVerifies) { check_corpus(Simplifier::kMeshopt, /*roundtrip=*/true); }

INSTANTIATE_TEST_SUITE_P(Acceptance, Corpus, ::testing::Values(Simplifier::kMeshopt, Simplifier::kOpenMesh),
                         [](const auto& info) { return std::string(simplifier_name(info.param)); });

// ---- the CLI path ----

// A few meshes covering the three importers: holes + open border (OFF), several components
// (OFF), binary STL, ASCII PLY.
const char* kCliMeshes[] = {"elephant-with-holes.off", "blobby_3cc.off", "pig.stl", "sphere.ply"};

class CorpusCli : public ::testing::TestWithParam<Simplifier> {};

// Property: `vgeo build MESH -o OUT --simplifier X && vgeo verify OUT` exits 0.
TEST_P(CorpusCli, BuildThenVerifyExitsZero) {
  const std::string backend = simplifier_name(GetParam());
  fs::path tmp = fs::temp_directory_path() / ("vgeo_accept_cli_" + std::to_string(::getpid()));
  fs::create_directories(tmp);
  for (const char* name : kCliMeshes) {
    fs::path mesh = data_dir() / "cgal" / "meshes" / name;
    ASSERT_TRUE(fs::exists(mesh)) << mesh << " missing: run tools/fetch-data";
    fs::path out = tmp / (std::string(name) + "." + backend + ".vgeodag");
    CliResult b = run_command("'" + cli_path() + "' build '" + mesh.string() + "' -o '" + out.string() +
                              "' --simplifier " + backend + " --threads 2");
    EXPECT_EQ(b.exit_code, 0) << name << " [" << backend << "] vgeo build:\n" << b.output;
    if (b.exit_code != 0) continue;
    CliResult v = run_command("'" + cli_path() + "' verify '" + out.string() + "' --threads 2");
    EXPECT_EQ(v.exit_code, 0) << name << " [" << backend << "] vgeo verify:\n" << v.output;
    EXPECT_NE(v.output.find("all invariants hold"), std::string::npos) << name << " [" << backend << "]\n" << v.output;
  }
  fs::remove_all(tmp);
}

INSTANTIATE_TEST_SUITE_P(Acceptance, CorpusCli, ::testing::Values(Simplifier::kMeshopt, Simplifier::kOpenMesh),
                         [](const auto& info) { return std::string(simplifier_name(info.param)); });

// ---- docs/acceptance/issue3.md corpus table (report writer, not a check) ----

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string table_row(const AcceptanceRun& r) {
  const BuildReport& b = r.build;
  std::vector<double> reductions;  // triangles(level L) / triangles(level L-1)
  uint64_t stuck = 0;
  for (size_t l = 0; l < b.levels.size(); ++l) {
    stuck += b.levels[l].stuck_groups;
    if (l > 0 && b.levels[l - 1].triangles > 0)
      reductions.push_back(double(b.levels[l].triangles) / double(b.levels[l - 1].triangles));
  }
  std::string verdict = r.ok() ? "ok" : "FAIL";
  if (!r.ok() && !r.error.empty()) verdict = "FAIL (threw)";
  else if (!r.ok()) {
    verdict = "FAIL:";
    for (const ViolationCount& c : r.verify.counts) verdict += " " + c.code;
    for (const ViolationCount& c : r.roundtrip_verify.counts) verdict += " rt:" + c.code;
  }
  std::ostringstream s;
  s << "| " << r.mesh << " | " << r.backend << " | " << b.input_triangles << " | " << b.levels.size() << " | "
    << fmt("%.2f", b.input_triangles ? double(b.stored_triangles) / double(b.input_triangles) : 0.0) << " | "
    << fmt("%.3f", median(reductions)) << " | " << stuck << " | " << b.root_clusters << " / " << b.root_triangles
    << " | " << fmt("%.3f", r.verify.error_ratio.median) << " / " << fmt("%.3f", r.verify.error_ratio.max) << " | "
    << fmt("%.1f", r.seconds_build) << " / " << fmt("%.1f", r.seconds_verify) << " | " << verdict << " |";
  return s.str();
}

constexpr const char* kTableBegin = "<!-- corpus-table:begin (written by VGEO_WRITE_ACCEPTANCE=1 test_integration) -->";
constexpr const char* kTableEnd = "<!-- corpus-table:end -->";

// Writes the per-mesh table into docs/acceptance/issue3.md between the markers. Runs only
// when VGEO_WRITE_ACCEPTANCE=1 (it re-runs the whole corpus; the checks above are the tests).
TEST(AcceptanceReport, WriteIssue3CorpusTable) {
  const char* env = std::getenv("VGEO_WRITE_ACCEPTANCE");
  if (env == nullptr || std::string(env) != "1") {
    std::printf("report writer: set VGEO_WRITE_ACCEPTANCE=1 to regenerate docs/acceptance/issue3.md\n");
    return;
  }
  CorpusLoad load = load_corpus(SIZE_MAX);
  std::map<std::string, std::vector<std::string>> rows;  // mesh → rows (meshopt, openmesh)
  size_t ok = 0, total = 0;
  for (Simplifier s : {Simplifier::kMeshopt, Simplifier::kOpenMesh})
    for (const AcceptanceRun& r : run_corpus(load, s, /*roundtrip=*/true)) {
      rows[r.mesh].push_back(table_row(r));
      ok += r.ok();
      ++total;
    }
  std::ostringstream t;
  t << kTableBegin << "\n\n"
    << ok << " of " << total << " (mesh, backend) runs pass every check (" << load.meshes.size()
    << " meshes with triangles; b9.ply is a point cloud → MESH_EMPTY).\n\n"
    << "| mesh | backend | input tris | levels | stored/input | median level reduction | stuck groups | "
       "root clusters / tris | error ratio median / max | build / verify s | verdict |\n"
    << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const auto& [mesh, lines] : rows)
    for (const std::string& l : lines) t << l << "\n";
  t << "\n" << kTableEnd;

  fs::path doc = source_dir() / "docs" / "acceptance" / "issue3.md";
  std::string text;
  {
    std::ifstream in(doc);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  size_t a = text.find(kTableBegin), b = text.find(kTableEnd);
  if (a != std::string::npos && b != std::string::npos && b > a)
    text = text.substr(0, a) + t.str() + text.substr(b + std::string(kTableEnd).size());
  else
    text += "\n" + t.str() + "\n";
  fs::create_directories(doc.parent_path());
  std::ofstream out(doc);
  out << text;
  ASSERT_TRUE(out.good()) << "cannot write " << doc;
}

}  // namespace
}  // namespace vgeo::test
