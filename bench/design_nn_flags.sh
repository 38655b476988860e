# The `design nn` settings the control benches share (sourced by control_table.sh, controller_sweep.sh and
# closed_loop_refine.sh), so that a sweep's variants differ from the control table's design only in the flags
# they name.
design_nn_flags=(--bandpass 20,1200 --nu 6 --nv 2 --ny 4 --sine-peak 0.6)
design_nn_hidden=8        # N1's hidden nodes
design_nn_iterations=150  # Levenberg-Marquardt iterations
design_nn_samples=48000   # samples of each training record

# design_nn_defaults FLAGS SEED: what FLAGS leave unset, as words: control_table.sh's hidden nodes,
# iterations and record samples, --seed SEED and sine share 0.75.
design_nn_defaults() {
  local flag value defaults=""
  for pair in "--hidden $design_nn_hidden" "--iterations $design_nn_iterations" "--samples $design_nn_samples" \
              "--seed $2" "--sine-share 0.75"; do
    flag=${pair% *}
    value=${pair#* }
    case " $1 " in *" $flag "*) ;; *) defaults+=" $flag $value" ;; esac
  done
  echo "$defaults"
}
