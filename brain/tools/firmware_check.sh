#!/usr/bin/env bash
# `make firmware-check`: prove the Brain's portable core builds for the V5 Brain.
#
#  1. Compiles every core source (brain/src/core/*.cpp) with arm-none-eabi-g++ for the V5's
#     Cortex-A9 (-mcpu=cortex-a9 -mfpu=neon-fp16 -mfloat-abi=softfp) with PROS's defines, in
#     gnu++20 (what PROS 4 compiles with) and gnu++17 (PROS 3, and the project's C++17 rule for
#     Brain code), with -Werror and the project's warnings, -fno-exceptions -fno-rtti.
#  2. Checks the objects reference no heap (malloc, operator new), exceptions, RTTI or printf.
#  3. Links the core into a probe program against newlib (no PROS), so every symbol it needs
#     exists on the target.
#  4. Reports each function's stack use (-fstack-usage) and fails above a bound.
#  5. Compiles src/pros_adapter.cpp too, when PROS's headers are at hand: after
#     `pros conduct apply kernel` (brain/include/api.h), or with PETE_PROS_INCLUDE=DIR.
# Outputs: build/firmware-check/ (objects, probe ELF, report.txt).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
BRAIN=$ROOT/brain
OUT=$ROOT/build/firmware-check
CXX=${ARM_CXX:-arm-none-eabi-g++}
NM=${ARM_NM:-arm-none-eabi-nm}
SIZE=${ARM_SIZE:-arm-none-eabi-size}
STACK_LIMIT=${PETE_STACK_LIMIT:-2048}

if ! command -v "$CXX" > /dev/null; then
  echo "firmware-check: $CXX not found; install Debian gcc-arm-none-eabi, libnewlib-arm-none-eabi" \
       "and libstdc++-arm-none-eabi-newlib (\`make arm-deps\` does it)" >&2
  exit 1
fi

MFLAGS=(-mcpu=cortex-a9 -mfpu=neon-fp16 -mfloat-abi=softfp)
# What PROS's common.mk adds to every C++ compile.
PROSFLAGS=(-Os -g -D_POSIX_THREADS -D_UNIX98_THREAD_MUTEX_ATTRIBUTES -D_POSIX_TIMERS
           -D_POSIX_MONOTONIC_CLOCK -ffunction-sections -fdata-sections -funwind-tables)
STRICT=(-Wall -Wextra -Werror -Wpedantic -Wshadow -Wconversion -Wno-psabi -fno-exceptions -fno-rtti)

rm -rf "$OUT"
mkdir -p "$OUT"
REPORT=$OUT/report.txt
: > "$REPORT"
say() { echo "$*" | tee -a "$REPORT"; }

say "firmware-check: $("$CXX" --version | head -n 1)"
say "target: ${MFLAGS[*]}"

mapfile -t SOURCES < <(find "$BRAIN/src/core" -name '*.cpp' | sort)
if [ "${#SOURCES[@]}" -eq 0 ]; then
  echo "firmware-check: no core sources under brain/src/core" >&2
  exit 1
fi

for std in gnu++20 gnu++17; do
  mkdir -p "$OUT/$std"
  for src in "${SOURCES[@]}"; do
    obj=$OUT/$std/$(basename "${src%.cpp}").o
    "$CXX" "${MFLAGS[@]}" "${PROSFLAGS[@]}" "${STRICT[@]}" -std=$std -fstack-usage \
      -iquote "$BRAIN/include" -c "$src" -o "$obj"
  done
  say "compiled ${#SOURCES[@]} core sources with -std=$std: ok"
done

# 2. Forbidden references in the core's objects (PROS 4 builds: gnu++20).
HEAP='malloc|calloc|realloc|free|_Znw.*|_Zna.*|_Zdl.*|_Zda.*'
EXCEPTIONS='__cxa_throw|__cxa_allocate_exception|__cxa_begin_catch|__cxa_rethrow|_ZSt.*__throw.*'
RTTI='__dynamic_cast|_ZTI.*|_ZTS.*'
FORBIDDEN="^($HEAP|$EXCEPTIONS|$RTTI|.*printf.*)\$"
# What the core needs from outside itself: undefined in some object, defined in none.
DEFINED=$("$NM" --defined-only "$OUT"/gnu++20/*.o | awk 'NF==3 {print $3}' | sort -u)
UNDEF=$(comm -23 <("$NM" -u "$OUT"/gnu++20/*.o | awk 'NF==2 {print $2}' | sort -u) \
                 <(echo "$DEFINED"))
BAD=$(echo "$UNDEF" | grep -E "$FORBIDDEN" || true)
if [ -n "$BAD" ]; then
  say "firmware-check: the core references heap/exception/RTTI/printf symbols:"
  say "$BAD"
  exit 1
fi
say "no heap, exception, RTTI or printf references; external symbols:" \
    "$(echo "$UNDEF" | tr '\n' ' ')"

# 3. Link probe against newlib, no PROS.
"$CXX" "${MFLAGS[@]}" "${PROSFLAGS[@]}" "${STRICT[@]}" -std=gnu++20 -iquote "$BRAIN/include" \
  -c "$BRAIN/tools/firmware_probe.cpp" -o "$OUT/firmware_probe.o"
"$CXX" "${MFLAGS[@]}" -specs=nosys.specs -Wl,--gc-sections "$OUT/firmware_probe.o" \
  "$OUT"/gnu++20/*.o -o "$OUT/firmware_probe.elf"
say "linked the core into a probe for the target: ok"
say "$("$SIZE" "$OUT/firmware_probe.elf" | tail -n 1 |
      awk '{print "probe size: text " $1 " B, data " $2 " B, bss " $3 " B"}')"

# 4. Stack use per function.
STACK=$(cat "$OUT"/gnu++20/*.su | awk -F'\t' '{print $2 "\t" $3 "\t" $1}' | sort -rn)
say "largest stack frames (bytes, kind, function):"
say "$(echo "$STACK" | head -n 5 | sed 's/^/  /')"
WORST=$(echo "$STACK" | head -n 1 | cut -f1)
if echo "$STACK" | cut -f2 | grep -qv '^static$'; then
  say "firmware-check: a core function has a dynamic stack frame (VLA or alloca):"
  say "$(echo "$STACK" | awk -F'\t' '$2 != "static"')"
  exit 1
fi
if [ "$WORST" -gt "$STACK_LIMIT" ]; then
  say "firmware-check: a stack frame of $WORST bytes exceeds the $STACK_LIMIT-byte bound"
  exit 1
fi

# 5. The PROS adapter, when PROS's headers are available.
PROS_INCLUDE=${PETE_PROS_INCLUDE:-}
if [ -z "$PROS_INCLUDE" ] && [ -f "$BRAIN/include/api.h" ]; then PROS_INCLUDE=$BRAIN/include; fi
if [ -n "$PROS_INCLUDE" ]; then
  "$CXX" "${MFLAGS[@]}" "${PROSFLAGS[@]}" "${STRICT[@]}" -std=gnu++20 -iquote "$BRAIN/include" \
    -isystem "$PROS_INCLUDE" -c "$BRAIN/src/pros_adapter.cpp" -o "$OUT/pros_adapter.o"
  say "compiled src/pros_adapter.cpp against PROS headers in $PROS_INCLUDE: ok"
else
  say "src/pros_adapter.cpp not compiled: PROS headers absent (apply the kernel template, or set" \
      "PETE_PROS_INCLUDE=DIR)"
fi
say "firmware-check: passed (report: ${REPORT#"$ROOT"/})"
