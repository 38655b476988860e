# The `design nn` settings the control benches share (sourced by control_table.sh and controller_sweep.sh),
# so that a sweep's variants differ from the control table's design only in the flags they name.
design_nn_flags=(--bandpass 20,1200 --nu 6 --nv 2 --ny 4 --samples 48000 --sine-peak 0.6)
design_nn_hidden=8        # N1's hidden nodes
design_nn_iterations=150  # Levenberg-Marquardt iterations
