# Sourced by tools/test, tools/demo and tools/fuzz: one way to build and report progress.
# On a terminal (stdout a TTY, CI unset) ninja's own status line shows what is being built and
# how far ([n/N]); in CI or when piped the compiler lines go to DIR/build.log, one line says
# what was built and how long it took, and a failure prints the log's tail.

vgeo_interactive() { [ -t 1 ] && [ -z "${CI:-}" ]; }

# vgeo_build LABEL DIR [cmake --build args...]
vgeo_build() {
  local label=$1 dir=$2; shift 2
  local start=$SECONDS
  if vgeo_interactive; then
    echo "build: $label ($dir)"
    cmake --build "$dir" "$@"
  else
    if ! cmake --build "$dir" "$@" >"$dir/build.log" 2>&1; then
      tail -60 "$dir/build.log" >&2
      echo "build: $label FAILED (log: $dir/build.log)" >&2
      return 1
    fi
    local steps
    steps=$(grep -c '^\[[0-9]*/[0-9]*\]' "$dir/build.log" || true)
    echo "build: $label: $steps steps in $((SECONDS - start)) s (log: $dir/build.log)"
  fi
}
