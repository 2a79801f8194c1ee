// Property tests run with a fixed seed (DEVELOPERS.md, "Property tests are deterministic"):
// every run checks the same cases, so a bug is caught every run or never. Linked into every
// test binary (tests/CMakeLists.txt), so ctest, tools/mutate and a binary run by hand agree.
// RapidCheck reads RC_PARAMS the first time a property runs, after static initialisation; the
// default goes first so RC_PARAMS from the environment wins key by key (RapidCheck keeps the
// last value of a key), e.g. the soak mode's random seed.
#include <cstdlib>
#include <string>

namespace {

const bool kFixedSeedInstalled = [] {
  std::string params = "seed=" VGEO_RC_SEED;
  if (const char* from_env = std::getenv("RC_PARAMS"); from_env && *from_env) params += std::string(" ") + from_env;
  setenv("RC_PARAMS", params.c_str(), 1);
  return true;
}();

}  // namespace
