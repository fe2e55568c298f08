#!/usr/bin/env bash
# Builds (Release) and runs the benchmarks; Google Benchmark JSON goes to
# build/bench/<name>.json, the console table to stdout. Medians of 5
# (rt_bench: percentiles of one long run).
#   scripts/bench.sh [extra Google Benchmark flags]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset release >/dev/null
cmake --build --preset release --target model_bench estimator_bench designer_bench \
  diagnosis_bench rt_bench
mkdir -p build/bench
for bench in model_bench estimator_bench designer_bench diagnosis_bench; do
  build/bin/$bench --benchmark_repetitions=5 \
    --benchmark_report_aggregates_only=true \
    --benchmark_out=build/bench/$bench.json --benchmark_out_format=json "$@"
done
# Latency distributions (percentiles as counters): one long repetition.
build/bin/rt_bench --benchmark_filter='^BM_(CycleCompute|SilRigRun|ModbusRoundTrip|WakeupVsCyclictest|CanCycleCodec|ConsoleImpact|LiveFeedIngest)(/.*)?$' \
  --benchmark_out=build/bench/rt_bench.json --benchmark_out_format=json "$@"
# The CAN round trip needs vcan0: inside the guest of scripts/vcan_vm.sh
# where the host kernel has no CAN (guest time: not a real machine's figures).
# (one line: the VM harness passes the command through its kernel command
# line, where a newline does not survive).
guest='build/bin/rt_bench --benchmark_filter=BM_CanRoundTrip --benchmark_out="$KCRIG_VM_SCRATCH/rtt.json" --benchmark_out_format=json >/dev/null 2>&1; cat "$KCRIG_VM_SCRATCH/rtt.json"'
scripts/vcan_vm.sh run sh -c "$guest" >build/bench/can_round_trip_vcan.json
echo "bench: JSON in build/bench/"
