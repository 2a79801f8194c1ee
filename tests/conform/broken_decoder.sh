#!/bin/sh
# A deliberately broken page decoder for tests/conform/decoder_conform_test.cpp, speaking the
# protocol of spec/conform.md §5: `broken_decoder.sh VGEO FILE` asks vgeo's own decoder
# (`VGEO conform hash FILE`) and then plants three faults:
#   - a truncated file is accepted with a made-up hash          (a verdict disagreement),
#   - a checksum failure is reported with its own code           (a code disagreement),
#   - a valid file whose size is a multiple of 7 gets another hash (a hash disagreement).
line=$("$1" conform hash "$2" 2>/dev/null | head -n 1)  # the verdict line (then memory=...)
case "$line" in
  "error[FORMAT_TRUNCATED]") echo 0123456789abcdef ;;
  "error[FORMAT_CHECKSUM]") echo "error[BAD_CRC]" ;;
  error*) echo "$line" ;;
  *)
    size=$(wc -c < "$2")
    if [ $((size % 7)) -eq 0 ]; then
      last=${line#???????????????}
      printf '%s%s\n' "${line%?}" "$(printf %s "$last" | tr 0123456789abcdef 1032547698badcfe)"
    else
      echo "$line"
    fi ;;
esac
