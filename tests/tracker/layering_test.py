#!/usr/bin/env python3
"""The dependency order of the source tree, checked on every #include.

Each tracker module is its own CMake target; a header of a module the target does not link could
still be included, so this reads every include and fails on one that runs against the order:
  tracker/<module> includes only the modules below it (MODULES);
  tracker/ includes nothing of drivers/, server/, proto/ or clients/;
  nothing outside tracker/experiments/ and tests/ includes tracker/experiments/.
Usage: layering_test.py SOURCE_DIR
"""
import pathlib
import re
import sys

# Each module and the modules it may include directly (transitively: theirs too).
MODULES = {
    "cli": [],
    "model": [],
    "motion": ["model"],
    "likelihood": ["model"],
    "filters": ["likelihood"],
    "search": ["filters", "motion"],
    "sim": ["likelihood", "motion"],
    "vision": ["likelihood"],
    "calibration": ["model", "cli"],
    "experiments": ["search", "sim", "vision", "calibration"],
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def allowed(module):
    seen, todo = {module}, list(MODULES[module])
    while todo:
        m = todo.pop()
        if m not in seen:
            seen.add(m)
            todo.extend(MODULES[m])
    return seen


def main():
    root = pathlib.Path(sys.argv[1])
    problems, checked = [], 0
    for path in sorted(root.glob("*/**/*")):
        if path.suffix not in (".h", ".cpp") or "build" in path.relative_to(root).parts[:1]:
            continue
        rel = path.relative_to(root).as_posix()
        top = rel.split("/")[0]
        if top not in ("tracker", "drivers", "server", "clients", "proto"):
            continue
        module = rel.split("/")[1] if top == "tracker" and rel.count("/") >= 2 else None
        if top == "tracker" and module not in MODULES:
            problems.append(f"{rel}: tracker/{module}/ is not a known module (add it to MODULES)")
            continue
        for inc in INCLUDE.findall(path.read_text(errors="replace")):
            checked += 1
            parts = inc.split("/")
            if top == "tracker":
                if parts[0] in ("drivers", "server", "proto", "clients"):
                    problems.append(f"{rel}: includes {inc}: the tracker knows no driver or server")
                elif parts[0] == "tracker" and len(parts) > 2 and parts[1] not in allowed(module):
                    problems.append(f"{rel}: includes {inc}: tracker/{module} may include only "
                                    f"{', '.join(sorted(allowed(module)))}")
            elif parts[:2] == ["tracker", "experiments"]:
                problems.append(f"{rel}: includes {inc}: the product never uses the experiments")
    for p in problems:
        print(p)
    print(f"{checked} includes checked, {len(problems)} against the order")
    return 1 if problems or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
