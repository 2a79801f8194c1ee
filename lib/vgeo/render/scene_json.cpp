// The scene file's JSON field readers (scene_json.h).
#include "vgeo/render/scene_json.h"

#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>

#include "vgeo/core/error.h"

namespace vgeo::scene_detail {

[[noreturn]] void bad(const Ctx& c, const std::string& code, const std::string& what) { fail(code, c.where, what); }

void check_keys(const Ctx& c, const json& obj, const std::string& path, std::initializer_list<const char*> allowed) {
  if (!obj.is_object()) bad(c, "SCENE_FIELD_TYPE", path + ": expected an object");
  std::set<std::string> ok(allowed.begin(), allowed.end());
  for (auto it = obj.begin(); it != obj.end(); ++it)
    if (!ok.count(it.key())) bad(c, "SCENE_UNKNOWN_FIELD", path + "." + it.key() + ": unknown field");
}

void require(const Ctx& c, const json& obj, const std::string& path, const char* key) {
  if (!obj.contains(key)) bad(c, "SCENE_MISSING_FIELD", path + "." + key + ": required");
}

double get_number(const Ctx& c, const json& obj, const std::string& path, const char* key, double def,
                  double lo, double hi, bool required, bool lo_open) {
  if (required) require(c, obj, path, key);
  if (!obj.contains(key)) return def;
  const json& v = obj[key];
  if (!v.is_number()) bad(c, "SCENE_FIELD_TYPE", path + "." + key + ": expected a number");
  double d = v.get<double>();
  if (!std::isfinite(d) || d < lo || (lo_open && d == lo) || d > hi) {
    std::ostringstream s;
    s << path << "." << key << ": " << d << " outside " << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
    bad(c, c.value_code, s.str());
  }
  return d;
}

bool get_bool(const Ctx& c, const json& obj, const std::string& path, const char* key, bool def) {
  if (!obj.contains(key)) return def;
  if (!obj[key].is_boolean()) bad(c, "SCENE_FIELD_TYPE", path + "." + key + ": expected true/false");
  return obj[key].get<bool>();
}

std::string get_string(const Ctx& c, const json& obj, const std::string& path, const char* key,
                       const std::string& def, bool required) {
  if (required) require(c, obj, path, key);
  if (!obj.contains(key)) return def;
  if (!obj[key].is_string()) bad(c, "SCENE_FIELD_TYPE", path + "." + key + ": expected a string");
  return obj[key].get<std::string>();
}

// The limit as the message writes it: "1e12", "1e6" (a power of ten), else the shortest decimal.
static std::string format_limit(double limit) {
  char buf[32];
  const double e = std::log10(limit);
  if (e == std::floor(e) && e >= 1) std::snprintf(buf, sizeof buf, "1e%d", int(e));
  else std::snprintf(buf, sizeof buf, "%g", limit);
  return buf;
}

std::vector<double> get_vector(const Ctx& c, const json& obj, const std::string& path, const char* key, size_t n,
                               double limit) {
  std::string p = path + "." + key;
  const auto it = obj.find(key);  // not const operator[]: undefined on a missing key
  if (it == obj.end() || !it->is_array() || it->size() != n) bad(c, "SCENE_FIELD_TYPE", p + ": expected an array of " + std::to_string(n) + " numbers");
  std::vector<double> out;
  for (const json& e : *it) {
    if (!e.is_number()) bad(c, "SCENE_FIELD_TYPE", p + ": expected numbers");
    double d = e.get<double>();
    if (!std::isfinite(d) || std::abs(d) > limit) bad(c, c.value_code, p + ": value not finite or beyond ±" + format_limit(limit));
    out.push_back(d);
  }
  return out;
}

const json& get_array(const Ctx& c, const json& obj, const std::string& path, const char* key, size_t max) {
  // find, not operator[]: a const json's operator[] on a missing key is undefined behaviour
  // (fuzz_camera_path: heap overflow on a path with "frames" but no "keyframes").
  static const json kAbsent;  // null: not an array
  const auto it = obj.find(key);
  return expect_array(c, it == obj.end() ? kAbsent : *it, path + key, max);
}

const json& expect_array(const Ctx& c, const json& v, const std::string& name, size_t max) {
  if (!v.is_array()) bad(c, "SCENE_FIELD_TYPE", name + ": expected an array");
  if (v.size() > max) bad(c, "SCENE_TOO_LARGE", name + ": more than " + std::to_string(max) + " entries");
  return v;
}

}  // namespace vgeo::scene_detail
