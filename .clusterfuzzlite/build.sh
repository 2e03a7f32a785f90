#!/bin/bash -eu
# ClusterFuzzLite / OSS-Fuzz build script for taut's cargo-fuzz targets.
#
# In the builder image (`.clusterfuzzlite/Dockerfile`) $SRC/taut holds the source, $OUT
# receives what the fuzzing infrastructure runs, and `cargo fuzz build` picks up the
# sanitizer and coverage flags the image sets. For each target in fuzz/fuzz_targets it puts in
# $OUT:
#   <target>                  the libFuzzer binary (`cargo fuzz build -O --debug-assertions`:
#                             optimised, with overflow checks, as CI's smoke runs them);
#   <target>_seed_corpus.zip  the committed seed corpus, fuzz/seeds/<target>/ (if not empty);
#   <target>.dict             its dictionary (fuzz/dict/<target>.dict; record.dict for
#                             record_decoder), if it has one.
#
# It also runs outside the container — a dry run that needs only a nightly toolchain and
# cargo-fuzz: OUT=$(mktemp -d) SRC=<dir holding a copy of the repo as taut/>
# RUSTUP_TOOLCHAIN=nightly bash .clusterfuzzlite/build.sh
cd "$SRC/taut"

cargo fuzz build -O --debug-assertions

built=fuzz/target/x86_64-unknown-linux-gnu/release
for source in fuzz/fuzz_targets/*.rs; do
  target=$(basename "${source%.rs}")
  cp "$built/$target" "$OUT/"
  seeds="fuzz/seeds/$target"
  if [ -d "$seeds" ] && [ -n "$(ls -A "$seeds")" ]; then
    rm -f "$OUT/${target}_seed_corpus.zip"
    (cd "$seeds" && zip -q -r "$OUT/${target}_seed_corpus.zip" .)
  fi
  case "$target" in
    record_decoder) dict=fuzz/dict/record.dict ;;
    *) dict="fuzz/dict/$target.dict" ;;
  esac
  if [ -f "$dict" ]; then
    cp "$dict" "$OUT/$target.dict"
  fi
done
