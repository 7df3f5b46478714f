#!/usr/bin/env bash
# Runs each libFuzzer target of a HVAC_TWIN_FUZZ build for a while, starting from its committed
# seed corpus, and prints executions and findings per target.
#
#   tests/fuzz/run.sh BUILD_DIR [SECONDS_PER_TARGET] [TARGET...]
#
# SECONDS_PER_TARGET defaults to 25 (what CI runs); give hours for a long campaign. New inputs
# go to BUILD_DIR/fuzz/<target>/corpus (not into the repository: minimise and commit the
# interesting ones by hand), crashes to BUILD_DIR/fuzz/<target>/crash-*. Exits non-zero on any
# finding, printing the reproducer: BUILD_DIR/tests/fuzz/hvac_twin_fuzz_<target> <crash file>.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="$(cd "$1" && pwd)"
seconds="${2:-25}"
shift $(($# < 2 ? $# : 2))
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then targets=(config decode check_reply checkpoint recording); fi

declare -A max_len=([config]=8192 [decode]=64 [check_reply]=300 [checkpoint]=4096 [recording]=4096)
status=0
for t in "${targets[@]}"; do
  exe="$build/tests/fuzz/hvac_twin_fuzz_$t"
  work="$build/fuzz/$t"
  mkdir -p "$work/corpus"
  dict=()
  if [ -f "$here/$t.dict" ]; then dict=(-dict="$here/$t.dict"); fi
  log="$work/last-run.log"
  set +e
  # -fork is not used: one process keeps the numbers simple. Leaks are findings too.
  "$exe" "$work/corpus" "$here/corpus/$t" "${dict[@]}" \
    -max_total_time="$seconds" -max_len="${max_len[$t]:-4096}" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$work/" >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$log" | grep -oE '[0-9]+$' || echo "?")
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 || true)
  corpus=$(find "$work/corpus" -type f | wc -l)
  if [ $rc -eq 0 ]; then
    echo "fuzz $t: ${seconds}s, $execs executions, $cov, $corpus new corpus inputs, no findings"
  else
    status=1
    echo "fuzz $t: FINDING (exit $rc) after $execs executions; log $log"
    grep -E 'ERROR|SUMMARY|invariant|Test unit written' "$log" | head -20 || true
  fi
done
exit $status
