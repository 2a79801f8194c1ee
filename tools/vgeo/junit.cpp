// JUnit XML writer (tools/vgeo/junit.h).
#include "junit.h"

#include <cstdio>

#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"

namespace vgeo::cli {

namespace {

// XML 1.0 text/attribute escaping; control characters XML cannot carry become '?'.
std::string escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char ch : s) {
    unsigned char u = static_cast<unsigned char>(ch);
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += (u < 0x20 && ch != '\n' && ch != '\t' && ch != '\r') ? '?' : ch;
    }
  }
  return out;
}

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", s < 0 ? 0.0 : s);
  return buf;
}

struct Totals {
  size_t tests = 0, failures = 0, skipped = 0;
  double seconds = 0;
  void add(const JunitCase& c) {
    ++tests;
    failures += c.failed;
    skipped += c.skipped && !c.failed;
    seconds += c.seconds;
  }
  std::string attributes() const {
    return " tests=\"" + std::to_string(tests) + "\" failures=\"" + std::to_string(failures) +
           "\" errors=\"0\" skipped=\"" + std::to_string(skipped) + "\" time=\"" + seconds_text(seconds) + "\"";
  }
};

}  // namespace

std::string junit_xml(const std::string& name, const std::vector<JunitSuite>& suites) {
  Totals all;
  std::string body;
  for (const JunitSuite& suite : suites) {
    Totals t;
    std::string cases;
    for (const JunitCase& c : suite.cases) {
      t.add(c);
      all.add(c);
      cases += "    <testcase classname=\"" + escape(c.classname) + "\" name=\"" + escape(c.name) + "\" time=\"" +
               seconds_text(c.seconds) + "\"";
      if (c.failed) {
        cases += ">\n      <failure type=\"" + escape(c.failure_type) + "\" message=\"" + escape(c.failure_message) +
                 "\">" + escape(c.failure_text) + "</failure>\n    </testcase>\n";
      } else if (c.skipped) {
        cases += ">\n      <skipped message=\"" + escape(c.skipped_message) + "\"/>\n    </testcase>\n";
      } else {
        cases += "/>\n";
      }
    }
    body += "  <testsuite name=\"" + escape(suite.name) + "\"" + t.attributes() + ">\n" + cases + "  </testsuite>\n";
  }
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"" + escape(name) + "\"" + all.attributes() +
         ">\n" + body + "</testsuites>\n";
}

void write_junit(const std::string& path, const std::string& name, const std::vector<JunitSuite>& suites) {
  std::string xml = junit_xml(name, suites);
  write_file_atomic(path, xml);
}

}  // namespace vgeo::cli
