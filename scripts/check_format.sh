#!/usr/bin/env bash
# Fails when a C++ source is not clang-format clean (Google base, .clang-format).
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(git ls-files '*.h' '*.cc' 2>/dev/null || find . -name '*.h' -o -name '*.cc')
clang-format --dry-run -Werror "${files[@]}"
echo "format: ${#files[@]} files clean"
