#!/usr/bin/env bash
# The Cortex-M4F firmware (examples/firmware): build it for
# thumbv7em-none-eabihf, print its footprint, run it under QEMU's MPS2-AN386
# board model (Cortex-M4 with FPU) and check that its estimates equal those
# of the host f32 run of the same code (examples/firmware_host.rs: the
# sweep's vectors, and a coast-down's samples through the order tracker,
# revolution counts included); the same
# for the build with the Givens block filter (--features givens).
#
#   .ci/firmware.sh            build, footprint, QEMU run, comparison
#   FIRMWARE_ICOUNT=1 .ci/firmware.sh
#                              also counts the instructions of each
#                              identifier update, order-tracker push and
#                              generated sample (QEMU one instruction per
#                              block, exec trace; about 7 minutes)
#
# Without qemu-system-arm (and no way to install it) the build and the
# footprint still run and a loud warning says the QEMU check was skipped.
set -euo pipefail
cd "$(dirname "$0")/.."

FW=examples/firmware
ELF=$FW/target/thumbv7em-none-eabihf/release/rotorid-firmware
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

banner() {
  echo "!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!"
  for line in "$@"; do echo "!! $line"; done
  echo "!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!!"
}

echo "-- firmware build (thumbv7em-none-eabihf, release)"
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true
# Every build names its target directory, so that the ELF paths above hold
# whatever CARGO_TARGET_DIR says.
(cd "$FW" && cargo build --release --target-dir target)

# Section sizes (bytes) and the two data arrays (table, measured sweep).
sec() {
  local hex
  hex=$(readelf -SW "$2" | sed 's/^ *\[ *[0-9]*\]//' | awk -v n="$1" '$1 == n { print $5 }')
  echo $((16#${hex:-0}))
}
sym() { readelf -sW "$2" | awk -v n="$1" '$8 ~ n { s += $3 } END { print s + 0 }'; }
footprint() {
  local elf=$1 vt text rodata data bss uninit table sweep code_flash
  vt=$(sec .vector_table "$elf"); text=$(sec .text "$elf"); rodata=$(sec .rodata "$elf")
  data=$(sec .data "$elf"); bss=$(sec .bss "$elf"); uninit=$(sec .uninit "$elf")
  table=$(sym '5table5TABLE' "$elf"); sweep=$(sym '5sweep5SWEEP' "$elf")
  code_flash=$((vt + text + rodata + data - table - sweep))
  echo "flash: .vector_table $vt + .text $text + .rodata $rodata + .data $data = $((vt + text + rodata + data)) bytes"
  echo "       of which the model table $table and the measured sweep $sweep: program $code_flash bytes"
  echo "static RAM: .data $data + .bss $bss + .uninit $uninit = $((data + bss + uninit)) bytes"
  STATIC_RAM=$((data + bss + uninit))
  if [ "$code_flash" -ge 32768 ] || [ "$STATIC_RAM" -ge 8192 ]; then
    echo "error: firmware over budget (32 KiB flash without tables, 8 KiB static RAM)" >&2
    exit 1
  fi
}

# The whole RAM: static RAM ($1 bytes) and the stack peak the firmware
# measured by painting ($2, its output), under 8 KiB.
ram_budget() {
  local peak
  peak=$(sed -n 's/^# stack peak of the program: \([0-9]*\) bytes.*/\1/p' "$2")
  if [ -z "$peak" ]; then
    echo "error: the firmware printed no stack peak" >&2
    exit 1
  fi
  echo "RAM: static $1 + stack peak $peak = $(($1 + peak)) bytes (budget 8192)"
  if [ $(($1 + peak)) -ge 8192 ]; then
    echo "error: firmware over the 8 KiB RAM budget (static RAM and stack peak)" >&2
    exit 1
  fi
}

echo "-- footprint"
footprint "$ELF"
RAM_STATIC=$STATIC_RAM

# The same program with the Givens block filter.
GV_ELF=$FW/target/givens/thumbv7em-none-eabihf/release/rotorid-firmware
echo "-- firmware build with the Givens block filter (--features givens)"
(cd "$FW" && cargo build --release --features givens --target-dir target/givens)
echo "-- footprint (Givens block filter)"
footprint "$GV_ELF"
GV_RAM_STATIC=$STATIC_RAM

if ! command -v qemu-system-arm >/dev/null 2>&1; then
  echo "-- qemu-system-arm missing: trying to install it"
  if [ "$(id -u)" = 0 ]; then
    (apt-get update -qq && apt-get install -y -qq qemu-system-arm) >/dev/null 2>&1 || true
  elif command -v sudo >/dev/null 2>&1; then
    (sudo -n apt-get update -qq && sudo -n apt-get install -y -qq qemu-system-arm) >/dev/null 2>&1 || true
  fi
fi
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  banner "WARNING: qemu-system-arm is not available and could not be installed:" \
         "the firmware was BUILT but NOT RUN; its estimates were NOT checked" \
         "against the host f32 run."
  exit 0
fi

QEMU=(qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -semihosting -nographic -kernel "$ELF")
echo "-- firmware run: ${QEMU[*]}"
timeout 300 "${QEMU[@]}" >"$OUT/target.txt"
cat "$OUT/target.txt"
ram_budget "$RAM_STATIC" "$OUT/target.txt"

echo "-- host run of the same code (f32)"
cargo run --quiet --example firmware_host >"$OUT/host.txt"
grep '^est ' "$OUT/target.txt" >"$OUT/target.est"
grep '^est ' "$OUT/host.txt" >"$OUT/host.est"
if [ ! -s "$OUT/target.est" ] || ! diff -u "$OUT/host.est" "$OUT/target.est"; then
  echo "error: the firmware's estimates differ from the host f32 run (diff above: - host, + target)" >&2
  exit 1
fi
echo "firmware (QEMU Cortex-M4F) and host f32 estimates identical: $(wc -l <"$OUT/target.est") lines"

echo "-- firmware run, Givens block filter"
timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -semihosting -nographic \
  -kernel "$GV_ELF" >"$OUT/target_gv.txt"
cat "$OUT/target_gv.txt"
ram_budget "$GV_RAM_STATIC" "$OUT/target_gv.txt"
cargo run --quiet --example firmware_host -- --givens >"$OUT/host_gv.txt"
grep '^est ' "$OUT/target_gv.txt" >"$OUT/target_gv.est"
grep '^est ' "$OUT/host_gv.txt" >"$OUT/host_gv.est"
if [ ! -s "$OUT/target_gv.est" ] || ! diff -u "$OUT/host_gv.est" "$OUT/target_gv.est"; then
  echo "error: the Givens-filter firmware's estimates differ from the host f32 run (diff above)" >&2
  exit 1
fi
echo "Givens-filter firmware (QEMU) and host f32 estimates identical: $(wc -l <"$OUT/target_gv.est") lines"

# Instructions between the two calls of each marker function around the
# identifier update, the order tracker's push and the generated sample (the
# three never nest): count, mean, min and max per call; per channel-sample
# (4 probes) for the push and the generator.
icount() {
  local ELF=$1 markers="" name addr
  for name in rotorid_update_marker rotorid_push_marker rotorid_sample_marker; do
    addr=$(readelf -sW "$ELF" | awk -v n="$name" '$8 == n { print $2 }')
    markers="$markers $name=$(printf '%08x' $((16#$addr & ~1)))"
  done
  rm -f "$OUT/trace"
  mkfifo "$OUT/trace"
  awk -v markers="$markers" '
    BEGIN { k = split(markers, kv, " "); for (i = 1; i <= k; i++) { split(kv[i], p, "="); name[p[2]] = p[1] } }
    /^Trace/ {
      split($0, a, "[][/]"); pc = a[3];
      if (pc in name) {
        if (cur == pc) { n[pc]++; s[pc] += c; if (c > mx[pc]) mx[pc] = c; if (!(pc in mn) || c < mn[pc]) mn[pc] = c
          if (c > 4000) { nb[pc]++; sb[pc] += c }
          cur = "" }
        else { cur = pc; c = 0 }
      } else if (cur != "") c++
    }
    END {
      # One generated sample per sample-marker pair (and one pair for the
      # call that finds the end of the coast-down): the pushes (blocks of 16
      # instants; a block with an average done is two calls) per
      # channel-sample are their total over the samples, 4 probes.
      for (m in name) if (name[m] == "rotorid_sample_marker") samples = n[m]
      for (m in n) {
        printf "%s: %d calls, mean %.1f, min %d, max %d instructions", name[m], n[m], s[m] / n[m], mn[m], mx[m]
        if (name[m] == "rotorid_sample_marker") printf " (%.2f per channel-sample, 4 probes)", s[m] / n[m] / 4
        if (name[m] == "rotorid_push_marker" && samples > 0)
          printf " (%d samples: %.2f per sample, %.2f per channel-sample, 4 probes)", samples, s[m] / samples, s[m] / samples / 4
        if (name[m] == "rotorid_push_marker" && nb[m] > 0 && n[m] > nb[m])
          printf "; %d calls over 4000 (a revolution end), mean %.1f; the other calls mean %.1f", nb[m], sb[m] / nb[m], (s[m] - sb[m]) / (n[m] - nb[m])
        printf "\n"
      }
    }
  ' "$OUT/trace" &
  awk_pid=$!
  timeout 1800 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -semihosting -nographic \
    -singlestep -d exec,nochain -D "$OUT/trace" -kernel "$ELF" >/dev/null
  wait "$awk_pid"
}

if [ "${FIRMWARE_ICOUNT:-0}" = 1 ]; then
  echo "-- instructions per update, per tracker push and per generated sample (QEMU, one instruction per translation block, exec trace)"
  # The trace runs at about 70 000 instructions a second: these builds run
  # the coast-down four times faster (--features short, the same speeds).
  echo "square-root-free block filter (the firmware, generated type Id; --features short):"
  (cd "$FW" && cargo build --release --features short --target-dir target/short)
  icount "$FW/target/short/thumbv7em-none-eabihf/release/rotorid-firmware"
  echo "Givens block filter (--features givens,short):"
  (cd "$FW" && cargo build --release --features givens,short --target-dir target/givens-short)
  icount "$FW/target/givens-short/thumbv7em-none-eabihf/release/rotorid-firmware"
  echo "dense filter (--features dense,short, same program otherwise):"
  (cd "$FW" && cargo build --release --features dense,short --target-dir target/dense)
  icount "$FW/target/dense/thumbv7em-none-eabihf/release/rotorid-firmware"
fi
