#pragma once
// JUnit XML reports (`--junit FILE` on `vgeo verify`, `vgeo compare`, `vgeo conform ...`) in the
// structure CI systems read (Jenkins, GitLab, GitHub test reporters, Azure):
//   <testsuites name tests failures errors skipped time>
//     <testsuite name tests failures errors skipped time>
//       <testcase classname name time> [<failure type message>text</failure> | <skipped message/>]
// One testcase per check or vector; a failing one carries its codes in `type` (the first code)
// and `message` (every code with its count). spec/errors.md §JUnit reports.
#include <string>
#include <utility>
#include <vector>

namespace vgeo::cli {

struct JunitCase {
  std::string classname;
  std::string name;
  double seconds = 0;
  bool skipped = false;
  std::string skipped_message;
  bool failed = false;
  std::string failure_type;     // the (first) code
  std::string failure_message;  // one line: every code and count
  std::string failure_text;     // details, one finding per line
};

inline JunitCase junit_case(std::string classname, std::string name) {
  JunitCase c;
  c.classname = std::move(classname);
  c.name = std::move(name);
  return c;
}

struct JunitSuite {
  std::string name;
  std::vector<JunitCase> cases;
};

std::string junit_xml(const std::string& name, const std::vector<JunitSuite>& suites);
// Written atomically (temporary + rename); IO_WRITE (exit 4) when it cannot be.
void write_junit(const std::string& path, const std::string& name, const std::vector<JunitSuite>& suites);

}  // namespace vgeo::cli
