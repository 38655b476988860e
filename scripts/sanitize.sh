#!/usr/bin/env bash
# The sanitizer runs CI does after the main tests (issue #10, item 5; item 1's brief fuzz runs):
#   1. AddressSanitizer + UBSan (less four checks ASan covers; PANELBASS_ASAN_UBSAN in CMakeLists.txt), clang
#      (build-asan): the whole test suite, every layer (the libraries instrumented, the test programs' own code
#      not: tests/CMakeLists.txt). The same build has the libFuzzer targets
#      (PANELBASS_FUZZ), and each target then runs for a few seconds on its seed corpus, so a parser regression
#      fails CI. The libraries are built without the fuzzer's coverage hooks
#      (PANELBASS_FUZZ_COVERAGE=OFF: a tenth of their compile time, and a few seconds of mutation gain little
#      from the guidance); scripts/fuzz.sh's long runs build with them;
#   2. ThreadSanitizer, clang (build-tsan): the engine tests (audio thread, control thread, lock-free
#      handover). clang, like the ASan build, so the precompiled headers (PANELBASS_PCH) serve it too. It links
#      the main build's models library (build/, brought up to date first) when that folder is a clang build,
#      instead of compiling the models under TSan (PANELBASS_PREBUILT_MODELS, models/CMakeLists.txt): their
#      code is single-threaded, and it was three quarters of this folder's compile time.
# Both at -O1 without debug info, to keep the instrumented Eigen code quick to compile (-O0 for the test
# programs and the command line compiled them in a third of the time, but the suite then ran 839 s against
# 255 s). Any sanitizer report fails the test that caused it.
#
#   bash scripts/sanitize.sh [FUZZ_SECONDS_PER_TARGET]     (default 10)
#   bash scripts/sanitize.sh build                         (only build the ASan folder: CI builds it at idle
#                                                           priority while the main stage builds and tests)
set -euo pipefail
cd "$(dirname "$0")/.."

build_only=0; [ "${1:-}" = build ] && build_only=1
fuzz_seconds=${1:-10}
# clang with its sanitizer and libFuzzer runtimes (the main build's packages are bootstrap.sh's).
bash scripts/install_packages.sh clang libclang-rt-14-dev ninja-build
jobs=$(nproc)
# Only the executables built here are run: the browser tests, the load bench (not built here), the
# executable documentation (whole user sessions through the command line; the main stage runs them) and the
# unit file's check (it needs the command, which the ThreadSanitizer build does not make) are left out.
not_built='_NOT_BUILT$|^web\.|^api\.load|^docs\.|^packaging\.'

# The concealed diagnosis scenarios are long numeric runs (seconds each in Release, minutes under ASan)
# over code the other diagnosis tests already exercise; the sanitizer stage leaves them out.
numeric_only='^DiagnosisScenarios'
# Seven more whole-pipeline diagnosis and identification runs (1.5-3 min each under ASan, 14 min of the
# stage's CPU) repeat, on other plants, the paths that the ones kept here walk under the sanitizer:
# CliDiagnose.HtmlReport... and CliDiagnose.TheCurrentOptedIn... (the whole locate / name / model / refit
# pipeline, its report and figures, the current channel), with JobKindsTest.Diagnose* and
# LinearIdentification.PanelExciterZhuAndBackx... (OE, Zhu and BackX on the transducer). All run in the main stage.
long_repeats='^CliDiagnose\.APlantBaselineIsDiagnosedThroughItsLinearisation$|^CliDiagnose\.FindsTheCubicSpringAndWritesTheReport$'
long_repeats+='|^Diagnosis\.VisibleAsymmetricStiffnessIsNamedFirst$|^Diagnosis\.VisibleClippingIsNamedSaturationFirst$'
long_repeats+='|^Diagnosis\.GivenBaselineMissingASensorOffsetGetsADcOffset$|^Diagnosis\.GivenBaselineWithTooShortADelayGetsADelay$'
long_repeats+='|^LinearIdentification\.OeZhuAndBackxRecoverTheLinearPlant$'
long_repeats+='|^Diagnosis\.APanelExcitersSmallFirstSampleIsNotTakenForDeadTime$|^Diagnosis\.AnOddMultisineRulesOutEvenOrderTerms'  # the same pipeline
long_repeats+='|^DiagnosisStructure\.ADiodeAfterTheDynamicsIsAWienerStaticNonlinearity$'  # the path of its between-filters twin
# Six more long numeric runs (30-110 s each under ASan, 7 min of the stage's CPU) whose paths shorter tests
# walk under the sanitizer too: the dX/N growth loop (NarxStructureGrowth.MaxHiddenOne...), NARX training on
# the transducer (JobKindsTest.IdentifyNarxOnTheVirtualTransducer), the chain's evaluation on the transducer
# (ChainEvaluationTest.EachProbeReportsTheThd...), the term-by-term attribution
# (ChainEvaluationTest.Attribution...) and the transducer's simulation (VirtualTransducer.*). All run in the main stage.
long_repeats+='|^NarxStructureGrowth\.TheDxOverNRule|^NarxTransducer\.NeuralModelBeatsTheBestLinearModel'
long_repeats+='|^JobKindsTest\.EvaluateIsTheChainsEvaluationOnTheVirtualTransducer$|^CliControl\.AttributeEvaluatesEachNonlinearTermAlone$'
long_repeats+='|^PlantSurvey\.PanelExciter'
# Eight more (68-300 s each under ASan on a loaded machine, 1188 of the stage's 3329 test-seconds; CI's
# time budget): the periodic multisine's whole diagnosis (its location on the empty lines: LocateResidual.*Periodic*),
# the evaluate job's level sweep (the evaluation: ChainEvaluationTest.*), the command line's --model-out (the
# same gray-box file: GrayBoxModelFile.*), `identify ss` trained, validated and analysed
# (CliIdentifySs.WienerHammerstein... and ...CubicStatesOnly..., SsTraining.*), the command line's NARX baseline
# (JobKindsTest.DiagnoseANarxBaseline...), the survey's harmonics (PlantSurvey.LinearPreset...), issue #36's
# selection reproduction (NarxTraining*.*) and the control command's chain (ChainEvaluationTest.*). All run in
# the main stage.
long_repeats+='|^Diagnosis\.APeriodicMultisineRecordIsIdentifiedAndItsEmptyLinesAreRead$|^JobKindsTest\.EvaluateLevelSweep'
long_repeats+='|^CliDiagnose\.ModelOutWritesTheDiagnosedModelThatValidateReads$|^CliIdentifySs\.TrainsAndValidateAndAnalyzeReadItsModel$'
long_repeats+='|^CliDiagnose\.ANarxBaselineStartsFromItsOwnSimulation$|^PlantSurvey\.HarmonicDistortion'
long_repeats+='|^NarxTrainingSelection\.KeepsTheRefinementWhenTheValidationRecordStartsMidStream$|^CliControl\.ControlSignal'
# Six more (30-125 s each under ASan, about a seventh of the stage's test-seconds; CI ran over its 40-minute
# budget, 2591 s on 3dffa27): the diagnose job's gray-box file (GrayBoxModelFile.* and
# JobKindsTest.DiagnoseFindsItsOwnBaseline... walk the file and the job), the OE order scan on the transducer
# (LinearIdentification.PanelExciterZhuAndBackx... fits OE on it), the cubic spring's extrapolation (the other
# SsTraining.* and the gradient tests walk the training), the flat chain on a linear plant (the other
# ChainEvaluationTest.* walk the evaluation) and the API's process-alone estimate on the transducer
# (ProcessAlone.* walk its computation). All run in the main stage.
long_repeats+='|^JobKindsTest\.DiagnoseStoresAGrayBoxModelThatADiagnosisTakesAsItsBaseline$'
long_repeats+='|^LinearIdentification\.PanelExciterOrderScanShowsItsKnee$'
long_repeats+='|^SsTraining\.ThePolynomialExtrapolatesACubicSpringBeyondTheTrainingAmplitude$'
long_repeats+='|^ChainEvaluationTest\.OnALinearPlantTheFeedforwardFlattensAndNothingDistorts$'
long_repeats+='|^ProcessAloneTest\.TheProcessAloneIsTheMechanicsAndSensorWithoutTheConverters$'
# Two tunes of a 10 s multisine each (the refine step with and without): Tune.KeepsAMirrorFilter... and
# Tune.WithoutASensor... walk the same tune, its refine step included, under the sanitizer. Run in the main stage.
long_repeats+='|^Tune\.TheFrictionRefinedOnQuietSinesLiftsTheCutAtLowLevelsToTheIssuesBar$'
# Three more tunes of a 10 s multisine on other plants (Rms(v), second-exciter without L2R2, a displacement sensor):
# the same path as the two above, other numbers. Run in the main stage.
long_repeats+='|^Tune\.AMechanicalResistanceRisingWithVelocityIsFittedAndCutNearTheResonance$'
long_repeats+='|^Tune\.TheRefinedFrictionScaleStaysFiniteWhereTheQuietSinesBarelyShowIt$'
long_repeats+='|^Tune\.ASensorThatHearsNoDistortionKeepsTheFilterUnverifiedAsWithoutOne$'
# The whole Tune pipeline through a JACK card (CardPipelineTest: excite, identify, design, verify while the
# card streams, asserting no xrun): under ASan the engine's periods run slower than JACK's real-time clock on
# a shared machine. Its parts run under the sanitizer in AlsaBackend.Jack*, ServerOnACardTest.* and the measurement's
# unit tests; the pipeline itself runs in the main stage.
long_repeats+='|^CardPipelineTest\.'
# Ninja for a new build folder (as bootstrap.sh); a folder configured before keeps its generator.
ninja_unless_configured() { [ -f "$1/CMakeCache.txt" ] || echo "-G Ninja"; }
started=$(date +%s)
CC=clang CXX=clang++ cmake -S . -B build-asan $(ninja_unless_configured build-asan) -DCMAKE_BUILD_TYPE=Sanitize -DCMAKE_CXX_FLAGS_SANITIZE="-O1" \
  -DPANELBASS_SANITIZE=ON -DPANELBASS_FUZZ=ON -DPANELBASS_FUZZ_COVERAGE=OFF >/dev/null
cmake --build build-asan -j"$jobs" --target dsp_tests models_tests engine_tests evaluation_tests api_tests cli_tests \
  csv_fuzz wav_fuzz model_json_fuzz chain_json_fuzz plant_json_fuzz http_fuzz record_upload_fuzz
[ "$build_only" = 1 ] && { echo "sanitize: the ASan folder built in $(($(date +%s) - started)) s" >&2; exit 0; }
# The main build's models library (bootstrap.sh's folder), when it is clang's; otherwise TSan compiles its own.
prebuilt_models=
if grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang' build/CMakeCache.txt 2>/dev/null; then
  cmake --build build -j"$jobs" --target panelbass_models
  prebuilt_models=$PWD/build/models/libpanelbass_models.a
fi
CC=clang CXX=clang++ cmake -S . -B build-tsan $(ninja_unless_configured build-tsan) -DCMAKE_BUILD_TYPE=Sanitize -DCMAKE_CXX_FLAGS_SANITIZE="-O1" \
  -DPANELBASS_TSAN=ON -DPANELBASS_PREBUILT_MODELS="$prebuilt_models" >/dev/null
cmake --build build-tsan -j"$jobs" --target engine_tests
built=$(date +%s)
# halt_on_error: a UBSan finding fails the test instead of scrolling past; leaks are reported at exit.
ASAN_OPTIONS="detect_leaks=1:abort_on_error=1" UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
  ctest --test-dir build-asan --output-on-failure -j2 -E "$not_built|$numeric_only|$long_repeats"
asan_done=$(date +%s)
FUZZ_BUILD=build-asan FUZZ_CONFIGURE=0 FUZZ_PARALLEL=2 bash scripts/fuzz.sh "$fuzz_seconds"
fuzz_done=$(date +%s)

# The JACK loopback tests are left out here: libjack is not instrumented, so TSan cannot see its
# synchronisation (they run under ASan above and in the main suite).
TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1" \
  ctest --test-dir build-tsan --output-on-failure -j2 -E "$not_built|AlsaBackend\.Jack"
finished=$(date +%s)
echo "sanitize: asan and tsan builds $((built - started)) s, asan tests $((asan_done - built)) s," \
  "fuzz $((fuzz_done - asan_done)) s, tsan tests $((finished - fuzz_done)) s" >&2
