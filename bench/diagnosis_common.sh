# Sourced by the diagnosis detection benches (diagnosis_detection.sh, diagnosis_family.sh): the vocabulary they
# run, and diagnosis_setup, which sets what both need.
# diagnosis_setup BUILD_DIR N_EST N_VAL: bin (the bench program), lengths (its --n-est/--n-val flags, N_EST and
# N_VAL overriding the defaults given), work (PANELBASS_WORK, or a temporary folder removed on exit) and start.
diagnosis_setup() {
  bin=${1:-build}/bin/diagnosis_detection_bench
  lengths="--n-est ${N_EST:-$2} --n-val ${N_VAL:-$3}"
  if [ -n "${PANELBASS_WORK:-}" ]; then
    work=$PANELBASS_WORK
    mkdir -p "$work"
  else
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
  fi
  start=$(date +%s)
}

all="resonance antiresonance delay cubic_stiffness asymmetric_stiffness force_factor inductance hysteresis saturation
thermal_compression dc_offset static_nonlinearity nonlinear_damping asymmetric_force_factor creep"
look_alikes="nonlinear_damping cubic_stiffness hysteresis force_factor asymmetric_force_factor asymmetric_stiffness inductance"
