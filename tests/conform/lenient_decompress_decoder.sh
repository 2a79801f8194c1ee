#!/bin/sh
# A page decoder that trusts its decompressor (as vgeo did with LZ4_decompress_safe before it
# checked match offsets, spec/format.md §5.1), for tests/conform/decoder_conform_test.cpp:
# `lenient_decompress_decoder.sh VGEO FILE` asks vgeo's own decoder (`VGEO conform hash FILE`)
# and accepts, with a made-up hash, every file vgeo rejects as FORMAT_DECOMPRESS.
line=$("$1" conform hash "$2" 2>/dev/null | head -n 1)
case "$line" in
  "error[FORMAT_DECOMPRESS]") echo 0123456789abcdef ;;
  *) echo "$line" ;;
esac
