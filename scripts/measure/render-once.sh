# Sourced by the measurement scripts beside it (line-measure.sh, reference-gap.sh).
#
#   render_once DIR NAME SHREFRACT RENDER_ARGS...
#
# `SHREFRACT render RENDER_ARGS --size 320x240` into DIR/NAME.exr and its float FITS twin DIR/NAME.fits
# (oiiotool, which linear_psnr.py reads), unless DIR/NAME.fits is there already: renders are
# kept and reused. The tool's progress lines go to DIR/render.log; a failing render prints its last
# line on stderr and returns 1, which stops a script run under `set -e`.
render_once() {
  local dir=$1 name=$2 tool=$3
  shift 3
  [ -f "$dir/$name.fits" ] && return
  if ! "$tool" render "$@" --size 320x240 -o "$dir/$name.exr" > /dev/null 2>> "$dir/render.log"; then
    echo "$dir/$name: render failed: $(tail -n 1 "$dir/render.log")" >&2
    return 1
  fi
  oiiotool "$dir/$name.exr" --ch R,G,B -d float -o "$dir/$name.fits"
}
