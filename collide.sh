#!/usr/bin/env bash
# Collide: set up, build and run on a fresh Debian 12 machine.
#
#   ./collide.sh run     install what is missing, build, run a short simulated campaign
#   ./collide.sh test    install what is missing, build, run the whole test suite (CTest)
#   ./collide.sh gui     install, build, open the lab GUI on the simulated rig
#   ./collide.sh bench   install, build, run the benchmarks (see docs/benchmarks.md)
#   ./collide.sh build   install and build only
#   ./collide.sh sanitize  clang build with AddressSanitizer + UndefinedBehaviorSanitizer:
#                          the unit, sim and peer suites and a short run of every fuzz target
#   ./collide.sh tsan    clang build with ThreadSanitizer: the threaded parts' tests
#   ./collide.sh fuzz    every fuzz target (or those named in COLLIDE_FUZZ_TARGETS,
#                        e.g. "shot_file catalog") for COLLIDE_FUZZ_RUNS inputs (default 10^6)
#
# `test` runs the whole suite, then the `sanitize` pass (as CI does).
# Environment: BUILD_DIR (default ./build), JOBS (default: number of cores),
# COLLIDE_OUT (where `run` writes shots, default ./shots), COLLIDE_SHOTS (default 20),
# COLLIDE_SKIP_SANITIZE=1 (test: skip the sanitizer pass).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$here"
BUILD_DIR="${BUILD_DIR:-$here/build}"
JOBS="${JOBS:-$(nproc)}"

# Debian 12 packages the project needs to build, test and run.
PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config git
  libeigen3-dev libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-videoio-dev libopencv-calib3d-dev
  libhdf5-dev libsqlite3-dev libtomlplusplus-dev libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libaravis-dev aravis-tools libusb-1.0-0-dev libgpiod-dev gpiod libmodbus-dev libv4l-dev
  qt6-base-dev qt6-charts-dev qt6-svg-dev libqt6opengl6-dev libgl-dev
  socat mbpoll python3-h5py hdf5-tools sqlite3 xvfb xauth
  # Sanitizer and fuzzing builds (./collide.sh sanitize, tsan, fuzz): clang,
  # its sanitizer and libFuzzer runtimes, llvm-symbolizer for readable reports.
  clang libclang-rt-14-dev llvm
  # The kernel-driver tests (ctest -L vm, tests/vm): Debian's own kernel and
  # the headers to build tests/vm/gpio-sim-collide against, booted under qemu.
  qemu-system-x86 busybox-static cpio kmod linux-image-amd64 linux-headers-amd64
  # The cluster test (ctest -L cluster, tests/app/slurm_cluster_test.cpp): a
  # single-node Slurm with its own munge key, started by the test as root.
  slurm-wlm munge
)

say() { printf '\033[1m==> %s\033[0m\n' "$*"; }
die() { printf 'collide.sh: %s\n' "$*" >&2; exit 1; }

ensure_packages() {
  local missing=() p
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || die "missing packages (${missing[*]}) and not root: install them as root, or run this as root"
    sudo="sudo"
  fi
  say "Installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -q
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# Builds the VM image the kernel-driver tests boot (idempotent, quick when up
# to date). Without qemu or the kernel packages the vm tests skip and say why.
prepare_vm() {
  say "Preparing the test VM (tests/vm/prepare.sh)"
  "$here/tests/vm/prepare.sh" "$BUILD_DIR/vm-image" || [ $? -eq 77 ]
}

build() {
  say "Configuring and building in $BUILD_DIR (Release, Ninja${CCACHE_DIR:+, ccache})"
  export CCACHE_BASEDIR="$here"
  cmake -S "$here" -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$BUILD_DIR" -j "$JOBS" "$@"
}

# A clang build with sanitizers in its own folder (no GUI: Qt is not
# instrumented, so the GUI's rig worker thread is not checked by the tsan
# pass). $1: folder, $2: sanitizers, further arguments: extra CMake options.
configure_sanitized() {
  local dir="$1" sanitizers="$2"
  shift 2
  say "Configuring in $dir (clang, -fsanitize=$sanitizers)"
  export CCACHE_BASEDIR="$here"
  cmake -S "$here" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCOLLIDE_BUILD_GUI=OFF -DCOLLIDE_BUILD_BENCH=OFF \
    -DCOLLIDE_SANITIZE="$sanitizers" "$@" >/dev/null
}
build_sanitized() {
  configure_sanitized "$@"
  say "Building in $1"
  cmake --build "$1" -j "$JOBS"
}

# Sanitizer settings: any report fails the test; LeakSanitizer ignores what
# the system libraries (GLib/Aravis, HDF5, OpenCV) keep until exit.
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$here/tests/sanitizers/lsan.supp:print_suppressions=0}"
export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$here/tests/sanitizers/tsan.supp}"

sanitize_pass() {
  local dir="${SANITIZE_BUILD_DIR:-$here/build-asan}"
  build_sanitized "$dir" address,undefined -DCOLLIDE_FUZZ=ON
  say "Unit, sim and peer suites under AddressSanitizer + UndefinedBehaviorSanitizer"
  # Four accuracy tests draw other random scenes under clang than under gcc
  # (their fixtures' random draws depend on the compiler) and then miss their
  # targets: accuracy findings for the vision core (issue 12), not memory or
  # UB errors. They run, and must pass, in the gcc build above. The last two
  # cases and the three test files below are left out for time (next comment).
  GTEST_FILTER="-SphereDetector.SphereCutByTheBorderIsMeasuredFromItsVisibleArc:SphereDetector.ThesisImagingSmallSpheres:FitSpin.TwoDotsPerFrameStillGiveTheSpin:AnalyzeBurstBadInput.SaturatedFramesAreSkippedAndFlagged:SequencerSim.ACameraSlowerThanRealTimeStillDeliversItsBurst:WallCampaignSim.ShotsThroughALensAreMeasuredThroughIt" \
    ctest --test-dir "$dir" --output-on-failure -j "$JOBS" -L 'unit|sim|peer' \
    -E 'camera_sim_imaging|cli_imaging_profiles|cli_calibrate_camera|lab_lens_sim'
  # Left out for time, not for a failure: these fire shots through the ray-
  # casting simulated camera (about 0.55 s a frame under ASan). Since the
  # sequencer waits on while frames keep arriving they pass under ASan too
  # (2026-11-25, fresh ASan build: camera_sim_imaging 103 s,
  # cli_imaging_profiles 194 s, cli_calibrate_camera 405 s, and the slow-camera
  # sequencer case 72 s), which CI's 45 minutes cannot spare. They run in the
  # gcc build above. So does the wall rig seen through a lens (2026-11-28:
  # 155 s under ASan; with it the wall campaign test took 519 s of its 600),
  # and lab_lens_sim (16 lab shots through the lens, 7 s in the gcc build;
  # up to 130 frames each at 0.55 s a frame: an estimated 20 minutes under
  # ASan).
  say "Fuzz targets, a short run each (./collide.sh fuzz for the long one)"
  ctest --test-dir "$dir" --output-on-failure -j "$JOBS" -L fuzz
}

# The threaded parts' tests: camera backends (sim, replay, V4L2, Aravis with
# its fake camera, live view), burst recorder and its ring, sequencer and lost
# devices, valve banks (sim, gpiod watchdog), regulators (sim, Modbus peer),
# the rig, saving and `collide analyze` (one thread per core), footage read
# from several threads, a shot's frames analysed in parallel
# (vision/frame_parallel), footage tracked a batch of frames per core at a
# time (vision/sphere_tracks), and the GUI's rig control thread (gui/rig_worker:
# RigWorker and its Mailbox, without the window).
TSAN_TESTS='^(analysis|vision|hw|app)/.*camera|sequencer|valve|ring_buffer|burst_recorder|regulator|rig_test|save_test|analyze|device_lost_sim|vision/footage|vision/frame_parallel|vision/sphere_tracks|gui/rig_worker'
tsan_pass() {
  local dir="${TSAN_BUILD_DIR:-$here/build-tsan}" targets=() t
  configure_sanitized "$dir" thread -DCOLLIDE_BUILD_GUI=ON
  # Only the test programs the pass runs (target folder_name for test
  # folder/name, tests/CMakeLists.txt); the app tests' build also makes `collide`.
  for t in $(ctest --test-dir "$dir" -N -R "$TSAN_TESTS" 2>/dev/null | sed -n 's/^ *Test *#[0-9]*: //p'); do
    targets+=(--target "${t//\//_}")
  done
  [ ${#targets[@]} -gt 0 ] || die "no test matches '$TSAN_TESTS' in $dir"
  say "Building $((${#targets[@]} / 2)) test programs in $dir"
  cmake --build "$dir" -j "$JOBS" "${targets[@]}"
  say "Threaded parts under ThreadSanitizer (camera backends, sequencer, valve timing, workers)"
  # Left out: three test cases fire simulated shots whose camera must render
  # within the burst's deadline; under TSan (5-15x slower) it misses it and
  # the shot fails on time ("the burst timed out: 34 of 70 post-trigger frames
  # arrived"; the silent-camera case then counts its first, healthy camera as
  # lost), not on a ThreadSanitizer report. The Aravis fake's 100 frames/s
  # stream now and then finds no free buffer because our instrumented thread
  # hands them back late (stats.underruns 1, wanted 0; 1 run in 6), again not
  # a report. Seen 2026-11-25, one core shared with three other jobs. They
  # run in the gcc build; the sanitize pass leaves out six for the same cause.
  GTEST_FILTER="-CameraSimImaging.LabProfileShowsAHighlightADarkLimbAndAMisalignedRig:CliCalibrateCamera.RecoversTheSimulatedLensAndTheAnalysisUsesIt:DeviceLostSim.ACameraThatDeliversNothingIsLostTheNextShotRefusedAndRecheckClearsIt:Formats/InProcessFake.FramesArriveBitExactAndInOrder/*" \
    ctest --test-dir "$dir" --output-on-failure -j "$JOBS" -R "$TSAN_TESTS"
}

fuzz_long() {
  local dir="${SANITIZE_BUILD_DIR:-$here/build-asan}" runs="${COLLIDE_FUZZ_RUNS:-1000000}" f name
  local only="${COLLIDE_FUZZ_TARGETS:-}"
  build_sanitized "$dir" address,undefined -DCOLLIDE_FUZZ=ON
  for f in "$dir"/tests/fuzz/*_fuzz; do
    name="$(basename "$f" _fuzz)"
    if [ -n "$only" ] && [[ " $only " != *" $name "* ]]; then continue; fi
    mkdir -p "$dir/tests/fuzz/corpus/$name"
    say "fuzz $name: $runs inputs (corpus kept in $dir/tests/fuzz/corpus/$name: a new run goes on from it)"
    # symbolize=0: the shot reader's helper process meets AddressSanitizer
    # reports inside libhdf5 on many inputs (contained and expected: "crashed
    # the HDF5 library"), and symbolising each one was half the run's time. A
    # finding is saved as crash-*; run the target on that file to see its
    # stack with names.
    (cd "$dir/tests/fuzz" && ASAN_OPTIONS="$ASAN_OPTIONS:symbolize=0" \
      "$f" -runs="$runs" -timeout=60 -rss_limit_mb=4096 -print_final_stats=1 \
      "$dir/tests/fuzz/corpus/$name" "$here/tests/fuzz/corpus/$name")
  done
}

run_main_job() {
  local out="${COLLIDE_OUT:-$here/shots}" shots="${COLLIDE_SHOTS:-20}"
  if [ -e "$out" ] && [ -n "$(ls -A "$out" 2>/dev/null)" ]; then
    out="$out/$(date +%Y%m%d-%H%M%S)"  # never mix with (or overwrite) an earlier run
  fi
  say "Firing a simulated campaign of $shots shots (config/sim.toml) into $out"
  "$BUILD_DIR/app/collide" campaign --rig "$here/config/sim.toml" --shots "$shots" --out "$out" --seed 1
  say "Analysing every shot"
  "$BUILD_DIR/app/collide" analyze "$out"
  "$BUILD_DIR/app/collide" shots "$out"
  say "Fitting the campaign (mu, beta_0, e)"
  "$BUILD_DIR/app/collide" fit "$out"
  say "Done. Shot files (HDF5), catalog.sqlite and fit/ (fit.json, plots) are in $out"
}

cmd="${1:-}"
case "$cmd" in
  run)
    ensure_packages
    build --target collide
    run_main_job
    ;;
  test)
    ensure_packages
    prepare_vm
    build
    say "Running the test suite"
    ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS"
    [ "${COLLIDE_SKIP_SANITIZE:-0}" = 1 ] || sanitize_pass
    ;;
  sanitize)
    ensure_packages
    sanitize_pass
    ;;
  tsan)
    ensure_packages
    tsan_pass
    ;;
  fuzz)
    ensure_packages
    fuzz_long
    ;;
  gui)
    ensure_packages
    build --target collide-gui
    exec "$BUILD_DIR/app/collide-gui" --rig "$here/config/sim.toml"
    ;;
  bench)
    ensure_packages
    prepare_vm
    build
    for b in "$BUILD_DIR"/bench/*_bench; do say "$(basename "$b")"; "$b"; done
    ;;
  build)
    ensure_packages
    build
    ;;
  *)
    sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'
    [ -z "$cmd" ] && exit 2
    die "unknown command '$cmd'"
    ;;
esac
