#pragma once
// What tests ask of a call that may fail: the stable code of the VgeoError it threw ("OK"
// when it returned), and a whole file's bytes.
#include <cstdint>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "vgeo/core/error.h"

namespace vgeo::test {

inline std::string error_code_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const VgeoError& e) {
    return e.error().code;
  }
  return "OK";
}

inline std::vector<uint8_t> read_file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), {});
}

}  // namespace vgeo::test
