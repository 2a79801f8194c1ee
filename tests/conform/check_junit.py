#!/usr/bin/env python3
"""Reads a JUnit XML report as CI systems do (xml.etree) and checks what they rely on beyond the
schema: the counts on <testsuites>/<testsuite> agree with the testcases, failures have a type and
a message. Prints one line per testcase: "SUITE :: CLASSNAME.NAME: passed|skipped|failed TYPE".
Exit 0 when the report is consistent, 1 otherwise (problems on stderr)."""
import sys
import xml.etree.ElementTree as ET


def main(path):
    problems = []
    root = ET.parse(path).getroot()
    if root.tag != "testsuites":
        problems.append("root is <%s>, not <testsuites>" % root.tag)
    totals = {"tests": 0, "failures": 0, "skipped": 0}
    for suite in root.findall("testsuite"):
        counts = {"tests": 0, "failures": 0, "skipped": 0}
        for case in suite.findall("testcase"):
            counts["tests"] += 1
            failure, skipped = case.find("failure"), case.find("skipped")
            state = "passed"
            if failure is not None:
                counts["failures"] += 1
                if not failure.get("type") or not failure.get("message"):
                    problems.append("%s: failure without type or message" % case.get("name"))
                state = "failed " + failure.get("type", "")
            elif skipped is not None:
                counts["skipped"] += 1
                state = "skipped"
            print("%s :: %s.%s: %s" % (suite.get("name"), case.get("classname"), case.get("name"), state))
        for key, value in counts.items():
            if int(suite.get(key, "0")) != value:
                problems.append("suite %s: %s=%s but %d testcases" % (suite.get("name"), key, suite.get(key), value))
            totals[key] += value
        if suite.get("errors", "0") != "0":
            problems.append("suite %s: errors=%s" % (suite.get("name"), suite.get("errors")))
    for key, value in totals.items():
        if int(root.get(key, "0")) != value:
            problems.append("testsuites: %s=%s but %d testcases" % (key, root.get(key), value))
    for p in problems:
        print(p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
