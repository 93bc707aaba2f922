#!/usr/bin/env bash
# Build and run the Pinocchio C++ reference benchmark against the pip wheels
# (pip install pin cmeel-eigen): -O3 -march=native, as lockstep's release build would be
# compared with target-cpu defaults (see README for the flags used there).
set -euo pipefail
P=$(python3 -c 'import cmeel, os; print(os.path.join(os.path.dirname(os.path.dirname(cmeel.__file__)), "cmeel.prefix"))')
out=${TMPDIR:-/tmp}/pinocchio_puma560
g++ -std=c++17 -O3 -march=native -DNDEBUG -DBOOST_MPL_LIMIT_LIST_SIZE=30 -DBOOST_MPL_LIMIT_VECTOR_SIZE=30 \
  -DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS -DBOOST_FUSION_INVOKE_MAX_ARITY=12 \
  -I"$P/include" -I"$P/include/eigen3" "$(dirname "$0")/pinocchio_puma560.cpp" \
  -L"$P/lib" -Wl,-rpath,"$P/lib" -lpinocchio_default -o "$out" 2>&1
"$out"
