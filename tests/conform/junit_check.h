#pragma once
// Checks a `--junit` report the way CI systems read it: xmllint against tests/conform/junit.xsd
// (the testsuites/testsuite/testcase/failure structure) and tests/conform/check_junit.py
// (xml.etree; counts agree with the testcases). Returns the parser's one line per testcase
// ("SUITE :: CLASSNAME.NAME: passed|skipped|failed TYPE"), or fails the test.
#include <gtest/gtest.h>

#include <string>

#include "support/paths.h"
#include "support/run_command.h"

namespace vgeo::test {

inline std::string checked_junit(const std::string& path) {
  const std::string dir = (source_dir() / "tests" / "conform").string();
  CliResult schema = run_command("xmllint --noout --schema '" + dir + "/junit.xsd' '" + path + "'");
  EXPECT_EQ(schema.exit_code, 0) << schema.output;
  CliResult parsed = run_command("python3 '" + dir + "/check_junit.py' '" + path + "'");
  EXPECT_EQ(parsed.exit_code, 0) << parsed.output;
  return parsed.output;
}

}  // namespace vgeo::test
