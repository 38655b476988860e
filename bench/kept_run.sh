# What the benches that work on a kept control_table.sh run (KEEP=DIR) share (sourced).

# require_kept SCRIPT DIR FILE...: exits 2, naming SCRIPT, if DIR lacks a FILE of such a run.
require_kept() {
  local script=$1 dir=$2
  shift 2
  for f in "$@"; do
    if [ ! -f "$dir/$f" ]; then echo "$script: $dir/$f is missing (run control_table.sh with KEEP=$dir)" >&2; exit 2; fi
  done
}

# transducer_plant: PLANT (a preset name, or a plant file made absolute), default panel-exciter.
transducer_plant() {
  local plant=${PLANT:-panel-exciter}
  if [ -f "$plant" ]; then plant=$(realpath "$plant"); fi
  echo "$plant"
}
