# Sourced by the measurement scripts beside it that run over the built-in scenes (aa-measure.sh,
# flicker-measure.sh, reference-gap.sh).
#
#   scene_args SHREFRACT OUTDIR [SCENE...]
#
# Sets `tool`, `out` and `scenes` (every built-in scene when none is given).
scene_args() {
  tool=$1 out=$2
  shift 2
  scenes=("$@")
  [ ${#scenes[@]} -gt 0 ] || scenes=(sphere cube torus glass-of-water)
}

#   bake_once DIR SCENE
#
# Bakes SCENE with --samples 4000 into DIR/field.shrf (its summary in DIR/bake.log) unless a field
# is there already.
bake_once() {
  [ -f "$1/field.shrf" ] || "$tool" bake "$2" --samples 4000 -o "$1/field.shrf" > "$1/bake.log"
}
