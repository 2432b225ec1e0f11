# The two commands a newcomer needs (both install missing Debian packages first):
#   make demo   build (Release) and run the main demo
#   make test   build with warnings as errors and run the whole test suite
# Further: make bench (every benchmark, quick) and make bench-full (at full size; or one of bench-core,
# bench-solvers, bench-pareto, bench-scaling, bench-stability), CSV + PNG in bench/results/; make sample-ppes (the
# sample PPEs of data/ppe/), bench-samples (every backend on them), bench-petsc (PETSc beside ours on them) and
# bench-mps-basic MPS_BASIC=DIR (MPS-Basic beside ours on its dam break);
# make test-sanitize; make docs (the API reference); make install PREFIX=/opt/sparsemps.
JOBS ?= $(shell nproc)
DEMO_OUT ?= runs/demo
# The benchmarks write their tables and charts to bench/results/local/ (not committed); UPDATE=1 writes the committed
# ones in bench/results/ that docs/ shows (make bench-full UPDATE=1).
RESULTS := $(if $(UPDATE),bench/results,bench/results/local)

.PHONY: deps docs install demo hydrostatic sample-ppes bench-samples bench-petsc test test-sanitize bench bench-full bench-distributed bench-distributed-step bench-distributed-scaling bench-distributed-3d bench-rebalance bench-migration bench-core bench-solvers poiseuille acoustic bench-acoustic rotating bench-rotating bench-pareto bench-scaling bench-stability structure bench-structure fsi bench-fsi bench-default-solver bench-phase-cost bench-solver-filter bench-thread-wait bench-mps-basic bench-free-surface-amg clean

deps:
	@bash scripts/install-deps.sh
	@mkdir -p $(RESULTS)

build/release/CMakeCache.txt: | deps
	cmake -S . -B build/release -DCMAKE_BUILD_TYPE=Release

# Every app is built (the README runs them from build/release next); the demo is the paper's Poiseuille set-up
# (seed 004: pushing-plate inlet, open outlet, 15 D, station at 10 D, to U t/D = 10) at Re = 40, coarse: 20 particles
# across instead of 50. About two minutes of running.
APPS = poiseuille hydrostatic rotating acoustic dambreak structure fsi run
demo: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target $(APPS)
	./build/release/apps/poiseuille/poiseuille --mode inlet --re 40 --across 20 --end-time 10 --out $(DEMO_OUT)
	/usr/bin/python3 scripts/sparsemps-plot $(DEMO_OUT)

hydrostatic: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target hydrostatic
	./build/release/apps/hydrostatic/hydrostatic --out runs/hydrostatic

# The library, its headers, CMake package, sparsemps.pc, the apps (bin/sparsemps-<app>) and their data into PREFIX, from
# a build of its own without tests and benchmarks (SHARED=OFF for a static library). docs/library.md.
PREFIX ?= /usr/local
SHARED ?= ON
install: deps
	cmake -S . -B build/install -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=$(PREFIX) \
	  -DBUILD_SHARED_LIBS=$(SHARED) -DSPARSEMPS_BUILD_TESTS=OFF -DSPARSEMPS_BUILD_BENCH=OFF
	cmake --build build/install -j$(JOBS)
	cmake --install build/install

# The API reference of the installed headers (Doxygen, docs/Doxyfile.in) into build/docs/html/index.html; nothing is
# compiled. The test ApiReferenceDocumented fails on any public member left without a /// comment.
docs: deps
	cmake -S . -B build/docs -DSPARSEMPS_BUILD_APPS=OFF -DSPARSEMPS_BUILD_TESTS=OFF -DSPARSEMPS_BUILD_BENCH=OFF
	cmake --build build/docs --target docs
	@echo "API reference: build/docs/html/index.html"

# One OpenMP thread per test while ctest runs JOBS tests at once: more threads than cores spin at every
# barrier, and the small scenes of the tests ran 10x slower that way.
test: deps
	cmake -S . -B build/test -DCMAKE_BUILD_TYPE=Release -DSPARSEMPS_WERROR=ON
	cmake --build build/test -j$(JOBS)
	cd build/test && OMP_NUM_THREADS=1 ctest --output-on-failure -j$(JOBS)

test-sanitize: deps
	# Optimised (-O2 -g): at -O0 under the sanitizers the scene tests ran past ctest's 900 s timeout.
	cmake -S . -B build/sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPARSEMPS_WERROR=ON -DSPARSEMPS_SANITIZE=ON
	cmake --build build/sanitize -j$(JOBS)
	cd build/sanitize && OMP_NUM_THREADS=1 ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	  ctest --output-on-failure -j$(JOBS) -LE install

# The quick pass over every benchmark: small sizes, the quick sweeps and a 2 x 3 corner of each stability map (the
# scenes' default gammas, 0.01 and 0.99, around their default step); CSV + PNG into
# bench/results/quick/ (not committed: the charts in docs/ come from make bench-full).
QUICK := bench/results/quick
bench: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_core bench_solvers bench_scaling poiseuille rotating
	mkdir -p $(QUICK)
	OMP_NUM_THREADS=1 ./build/release/bench/bench_core --sizes 1e4 1e5 --out $(QUICK)/core.csv
	/usr/bin/python3 bench/plot_core.py $(QUICK)/core.csv $(QUICK)/core.png
	./build/release/bench/bench_solvers --sizes 1e4,1e5 --out $(QUICK)/solvers.csv data/*.mtx data/ppe/*.mtx.gz
	/usr/bin/python3 bench/plot_solvers.py $(QUICK)/solvers.csv $(QUICK)/solvers.png
	$(MAKE) --no-print-directory bench-scaling SCALING_SIZES=1e4,3e4,1e5 SCALING_OUT=$(QUICK)
	OMP_NUM_THREADS=1 /usr/bin/python3 bench/pareto.py build/release --results $(QUICK) --runs runs/pareto-quick
	OMP_NUM_THREADS=1 /usr/bin/python3 bench/stability_maps.py build/release --gammas 0.01,0.99 --factors 0.5,1,2 \
	  --results $(QUICK) --runs runs/stability-quick

# Every benchmark at full size, into bench/results/ (the charts in docs/): core phases and solvers to 1e6, the
# per-step cost to 1e6 particles, error against wall time with the app defaults, the stability maps.
bench-full: bench-core bench-solvers bench-scaling bench-pareto bench-stability bench-default-solver bench-solver-filter

# One thread, like the per-step sweep: with two and a job on the other core, the lists took 1.6-6.5x longer than on one.
bench-core: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_core
	OMP_NUM_THREADS=1 ./build/release/bench/bench_core --out $(RESULTS)/core.csv
	/usr/bin/python3 bench/plot_core.py $(RESULTS)/core.csv $(RESULTS)/core.png

# The distributed PPE on 1 and 2 MPI ranks at 1e5 and 1e6 unknowns, one thread per rank (docs/scaling.md): a row per
# run appended to bench/results/distributed_ppe.csv, with the machine's load at its start.
bench-distributed: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_distributed_ppe
	for n in 1e5 1e6; do for p in 1 2; do \
	  OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np $$p \
	    ./build/release/bench/bench_distributed_ppe --fluid $$n --out $(RESULTS)/distributed_ppe.csv || exit 1; \
	done; done

# The step on 1 and 2 ranks (bench_distributed_step, the dam break; docs/scaling.md): DSTEP_SIZES fluid particles,
# DSTEP_STEPS timed steps each, appended to bench/results/distributed_step.csv.
DSTEP_SIZES ?= 1e5 1e6
DSTEP_STEPS ?= 5
bench-distributed-step: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_distributed_step
	for n in $(DSTEP_SIZES); do for p in 1 2; do \
	  OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np $$p \
	    ./build/release/bench/bench_distributed_step --fluid $$n --steps $(DSTEP_STEPS) \
	    --out $(RESULTS)/distributed_step.csv || exit 1; \
	done; done

# Strong (1e5, 1e6 on 1 and 2 ranks) and weak scaling (1e5 and 5e5 per rank) of the dam break's step, twice over,
# into a fresh bench/results/distributed_scaling.csv; then the communication model fitted to it and the projection
# to 1e8 particles on 1,000 ranks (bench/scaling_model.py, docs/scaling.md). About 5 minutes; run it on an idle machine.
bench-distributed-scaling: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_distributed_step
	rm -f $(RESULTS)/distributed_scaling.csv
	for round in 1 2; do for run in "1 1e5 5" "2 1e5 5" "2 2e5 5" "1 5e5 3" "2 1e6 3" "1 1e6 3"; do set -- $$run; \
	  OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np $$1 \
	    ./build/release/bench/bench_distributed_step --fluid $$2 --steps $$3 \
	    --out $(RESULTS)/distributed_scaling.csv || exit 1; \
	done; done
	/usr/bin/python3 bench/scaling_model.py --step-csv $(RESULTS)/distributed_scaling.csv \
	  --ppe-csv bench/results/distributed_ppe.csv --png $(RESULTS)/scaling_model.png

# The 3-D dam break's step (SPHERIC Test 2, bench_distributed_step --dim 3) on 1 and 2 ranks at four spacings with
# the app's solver and kind weights, into a fresh bench/results/distributed_step_3d.csv; then the 3-D model and its
# projection to 1e9 particles on 10,000 ranks (docs/scaling.md). About 8 minutes and 6 GB; run it on an idle machine.
DSTEP3_WEIGHTS ?= 1 0.6 0.25 0.01
DSTEP3_BENCH ?= ./build/release/bench/bench_distributed_step
bench-distributed-3d: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_distributed_step
	rm -f $(RESULTS)/distributed_step_3d.csv
	for run in "1 0.05" "2 0.05" "1 0.03" "2 0.03" "1 0.02" "2 0.02" "1 0.0116" "2 0.0116"; do set -- $$run; \
	  OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np $$1 \
	    $(DSTEP3_BENCH) --dim 3 --l0 $$2 --steps 3 --solver auto --kind-weights $(DSTEP3_WEIGHTS) \
	    --out $(RESULTS)/distributed_step_3d.csv || exit 1; \
	done
	/usr/bin/python3 bench/scaling_model.py --dim 3 --step-csv $(RESULTS)/distributed_step_3d.csv \
	  --ppe-csv bench/results/distributed_ppe.csv --png $(RESULTS)/scaling_model_3d.png

# AMG kept across migrations (docs/scaling.md): the dam break (MIGRATION_DIM 2: the classic column, 3: SPHERIC Test 2)
# at about MIGRATION_FLUID fluid particles with `auto`, on 1 rank and on 2 ranks migrating every step and every 20th,
# MIGRATION_STEPS timed steps each: rows appended to bench/results/migration_<dim>d.csv, the step-by-step traces
# into bench/results/migration_trace_<dim>d.csv and its figure. About 8 minutes at the 2-D defaults.
MIGRATION_DIM ?= 2
MIGRATION_FLUID ?= 1e6
MIGRATION_STEPS ?= 40
bench-migration: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_distributed_step
	for run in "1 20" "2 1" "2 20"; do set -- $$run; \
	  OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np $$1 \
	    ./build/release/bench/bench_distributed_step --dim $(MIGRATION_DIM) --fluid $(MIGRATION_FLUID) \
	    --steps $(MIGRATION_STEPS) --solver auto --migrate-every $$2 --trace build/release/migration_trace_$$1_$$2.csv \
	    --out $(RESULTS)/migration_$(MIGRATION_DIM)d.csv || exit 1; \
	done
	(head -1 build/release/migration_trace_1_20.csv; for run in 1_20 2_1 2_20; do \
	  tail -n +2 build/release/migration_trace_$$run.csv; done) > $(RESULTS)/migration_trace_$(MIGRATION_DIM)d.csv
	/usr/bin/python3 bench/plot_migration.py $(RESULTS)/migration_trace_$(MIGRATION_DIM)d.csv \
	  $(RESULTS)/migration_trace_$(MIGRATION_DIM)d.png $(MIGRATION_DIM)

# The dam break's load imbalance on 2 ranks against time, one trace per rebalance threshold (docs/scaling.md, "Keeping
# the cuts"): concatenated into bench/results/rebalance_trace.csv, the runs' rows appended to rebalance.csv, the figure.
REBALANCE_THRESHOLDS ?= inf 1.10 1.05 1.02 1.01 1
bench-rebalance: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_distributed_step
	for t in $(REBALANCE_THRESHOLDS); do \
	  OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpirun --oversubscribe -np 2 \
	    ./build/release/bench/bench_distributed_step --fluid 800 --steps 2000 --threshold $$t --migrate-every 1 \
	    --trace build/release/rebalance_trace_$$t.csv --out $(RESULTS)/rebalance.csv || exit 1; \
	done
	t0=$(firstword $(REBALANCE_THRESHOLDS)); (head -1 build/release/rebalance_trace_$$t0.csv; \
	  for t in $(REBALANCE_THRESHOLDS); do tail -n +2 build/release/rebalance_trace_$$t.csv; done) \
	  > $(RESULTS)/rebalance_trace.csv
	/usr/bin/python3 scripts/plot_rebalance.py $(RESULTS)/rebalance_trace.csv $(RESULTS)/rebalance_trace.png

SOLVER_SIZES ?= 1e4,1e5,1e6
bench-solvers: deps build/release/CMakeCache.txt
	test -e data/ppe/channel_1e4.mtx.gz || $(MAKE) --no-print-directory sample-ppes
	cmake --build build/release -j$(JOBS) --target bench_solvers
	./build/release/bench/bench_solvers --sizes $(SOLVER_SIZES) --limit "eigen-bicgstab=200000" \
	  --out $(RESULTS)/solvers.csv data/*.mtx data/ppe/*.mtx.gz
	/usr/bin/python3 bench/plot_solvers.py $(RESULTS)/solvers.csv $(RESULTS)/solvers.png

# The sample PPEs of real scenes (inlet channel, screw channel, dam break, 3-D dam break; data/ppe/,
# docs/solvers.md#sample-matrices): SAMPLES=small (the ~1e4 cases, half a minute), large (the ~1e5 ones, about 19
# minutes), huge (the 3-D ~1e6 one, 20 minutes, 1.2 GB) or all; the matrices stay out of git, their index
# (data/ppe/index.csv) is in it.
SAMPLES ?= small
sample-ppes: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target poiseuille rotating dambreak
	/usr/bin/python3 scripts/make_sample_ppes.py build/release $(SAMPLES)

# Every backend on the sample PPEs alone (those of data/ppe/ on disk: the ~1e4 ones, made first if missing; the ~1e5
# ones once made).
bench-samples: deps build/release/CMakeCache.txt
	test -e data/ppe/channel_1e4.mtx.gz || $(MAKE) --no-print-directory sample-ppes
	cmake --build build/release -j$(JOBS) --target bench_solvers
	./build/release/bench/bench_solvers --files-only --limit "eigen-bicgstab=200000" \
	  --out $(RESULTS)/solvers_samples.csv data/ppe/*.mtx.gz

# PETSc's methods (GAMG, hypre through PETSc, ICC, Jacobi) beside ours on the sample PPEs on disk, one thread
# (bench/petsc_samples.py; docs/solvers.md#petsc): CSV and chart in bench/results/.
bench-petsc: deps build/release/CMakeCache.txt
	test -e data/ppe/channel_1e4.mtx.gz || $(MAKE) --no-print-directory sample-ppes
	cmake --build build/release -j$(JOBS) --target bench_solvers
	/usr/bin/python3 bench/petsc_samples.py build/release --results $(RESULTS)

# MPS-Basic (a public C++ MPS code) beside ours on its own dam break, one thread each (bench/mps_basic.py;
# docs/benchmarks.md): MPS_BASIC is a checkout of github.com/MPS-Basic/MPS-Basic, built from its sources for the
# measurement with Debian's Eigen, yaml-cpp and fast-cpp-csv-parser. About 20 minutes.
MPS_BASIC ?=
bench-mps-basic: deps build/release/CMakeCache.txt
	@test -n "$(MPS_BASIC)" || { echo "give MPS_BASIC=path/to/a/checkout/of/MPS-Basic"; exit 2; }
	dpkg -s libyaml-cpp-dev libfccp-dev >/dev/null 2>&1 || apt-get install -y --no-install-recommends libyaml-cpp-dev libfccp-dev
	cmake --build build/release -j$(JOBS) --target dambreak
	/usr/bin/python3 bench/mps_basic.py --mps-basic $(MPS_BASIC) --ours build/release

# The periodic channel in both modes at 50 across to 20 D/U (a few minutes each), with profile plots.
poiseuille: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target poiseuille
	./build/release/apps/poiseuille/poiseuille --mode body-force --end-time 20 --out runs/poiseuille/body-force
	./build/release/apps/poiseuille/poiseuille --mode couette --end-time 20 --out runs/poiseuille/couette
	/usr/bin/python3 apps/poiseuille/plot_profile.py runs/poiseuille/body-force/profile.csv runs/poiseuille/body-force/profile.png
	/usr/bin/python3 apps/poiseuille/plot_profile.py runs/poiseuille/couette/profile.csv runs/poiseuille/couette/profile.png

# Acoustic scenes (seed 001) at the paper's settings, then the map and centreline panels of docs/acoustics.md.
acoustic: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target acoustic
	for c in free hard mur two-pulse flow; do ./build/release/apps/acoustic/acoustic --case $$c --frames 0 || exit 1; done
	/usr/bin/python3 bench/plot_acoustic.py maps runs/acoustic $(RESULTS)/acoustic_maps.png
	/usr/bin/python3 bench/plot_acoustic.py centreline runs/acoustic $(RESULTS)/acoustic_centreline.png

# Error against CFL and against spacing (seed 001 Fig. 2-3): ~7 min on 2 cores.
bench-acoustic: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target acoustic
	/usr/bin/python3 bench/acoustic_studies.py --app build/release/apps/acoustic/acoustic cfl --out $(RESULTS)/acoustic_cfl.csv
	/usr/bin/python3 bench/acoustic_studies.py --app build/release/apps/acoustic/acoustic spacing --out $(RESULTS)/acoustic_spacing.csv
	/usr/bin/python3 bench/plot_acoustic.py cfl $(RESULTS)/acoustic_cfl.csv $(RESULTS)/acoustic_cfl.png
	/usr/bin/python3 bench/plot_acoustic.py spacing $(RESULTS)/acoustic_spacing.csv $(RESULTS)/acoustic_spacing.png

# Rotating boundaries (seed 000): Taylor-Couette at 20 across to 1 s (in 3-D at 10 across), and the screw channel in
# both models at 24 across to 0.5 s (the paper's 49 across: --across 49, or leave --across out), with the plots of
# docs/rotating.md.
ROTATING_ACROSS ?= 24
rotating: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target rotating
	OMP_NUM_THREADS=1 ./build/release/apps/rotating/rotating --scene couette --out runs/rotating/couette
	OMP_NUM_THREADS=1 ./build/release/apps/rotating/rotating --scene couette --dim 3 --out runs/rotating/couette-3d
	# Status 2 is a check missed (reported in the check lines, docs/rotating.md): plot anyway.
	OMP_NUM_THREADS=1 ./build/release/apps/rotating/rotating --scene channel --model both --across $(ROTATING_ACROSS) \
	  --average 0.5 --out runs/rotating/channel || [ $$? -eq 2 ]
	/usr/bin/python3 apps/rotating/plot_rotating.py couette $(RESULTS)/rotating_couette.png runs/rotating/couette \
	  runs/rotating/couette-3d
	/usr/bin/python3 apps/rotating/plot_rotating.py channel $(RESULTS)/rotating_channel.png \
	  --reference bench/results/rotating_reference.csv \
	  runs/rotating/channel/moving runs/rotating/channel/fixed

# Elastic structures (seed 003 §2.2): the plate and CSM3 at H/10 with their default outputs (about 2.5 minutes);
# bench-structure runs docs/structures.md's study (three spacings each, the hourglass sweep, speed; ~25 min).
structure: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target structure
	OMP_NUM_THREADS=1 ./build/release/apps/structure/structure --scene plate --out runs/structure/plate || [ $$? -eq 2 ]
	OMP_NUM_THREADS=1 ./build/release/apps/structure/structure --scene csm3 --out runs/structure/csm3 || [ $$? -eq 2 ]

bench-structure: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target structure
	/usr/bin/python3 bench/plate_reference.py
	/usr/bin/python3 bench/structure_study.py build/release --results $(RESULTS)

# Fluid-structure interaction (seed 003 §2.3-2.4): the dam break on the elastic plate and the rubber gate at their
# coarse defaults (a few minutes); bench-fsi runs docs/fsi.md's study and stability map (about an hour on 2 cores).
fsi: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target fsi
	OMP_NUM_THREADS=1 ./build/release/apps/fsi/fsi --scene plate --out runs/fsi/plate
	OMP_NUM_THREADS=1 ./build/release/apps/fsi/fsi --scene gate --out runs/fsi/gate

# the default solver (auto) against the classic IC-CG path on every scene, alternating, one run at a time (~4 min)
bench-default-solver: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS)
	/usr/bin/python3 bench/default_solver.py build/release --results $(RESULTS)

# cost per particle of each phase against N, one and two threads, peak RSS: the 2-D channel, then the 3-D dam break
# (~10 min; needs an idle machine). OLD=BUILD_DIR [OLD_LABEL=commit] runs an older build in turn with this one
# (2-D three times each, ~35 min in all)
bench-phase-cost: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_scaling dambreak
	/usr/bin/python3 bench/phase_cost.py build/release --results $(RESULTS) \
	  $(if $(OLD),--against $(OLD) --against-label $(or $(OLD_LABEL),old) --repeat 3)
	/usr/bin/python3 bench/phase_cost.py build/release --dim 3 --sizes 1e4,1e5 --results $(RESULTS) \
	  $(if $(OLD),--against $(OLD) --against-label $(or $(OLD_LABEL),old))

# auto's hierarchy kept across a moving free surface: the seed column with auto and Jacobi-CG at H/50 and H/100, one
# run at a time (~40 min); OLD=BUILD_DIR adds an older build's auto at H/50
bench-free-surface-amg: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target dambreak
	/usr/bin/python3 bench/free_surface_amg.py build/release --spacings 50,100 --results $(RESULTS) \
	  $(if $(OLD),--old $(OLD) --old-spacings 50)

# one thread against two with OpenMP's active and passive wait policies, idle and beside a busy process (~5 min)
bench-thread-wait: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_scaling dambreak
	/usr/bin/python3 bench/thread_wait.py build/release --results $(RESULTS)

# hypre-pcg's AMG built on the filtered PPE against the unfiltered one, tank PPEs at 4.1 and 3.1 l0 (~3 min)
bench-solver-filter: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_solvers
	/usr/bin/python3 bench/solver_filter.py build/release --results $(RESULTS)

bench-fsi: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target fsi
	/usr/bin/python3 bench/fsi_stability.py build/release --results $(RESULTS)
	/usr/bin/python3 bench/fsi_study.py build/release --results $(RESULTS)

# Barrel pressure at the corners for gamma in {0, 0.01, 0.05, 0.5, 0.99, 1}, with and without the corrective matrix
# and particle shifting (24 runs, ~5 min).
bench-rotating: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target rotating
	OMP_NUM_THREADS=1 /usr/bin/python3 bench/rotating_corners.py --app build/release/apps/rotating/rotating \
	  --out $(RESULTS)/rotating_corners.csv

# Error against wall time (design section 7) for the body-force channel and Taylor-Couette: spacing x backend, then
# tolerance and gamma one at a time; one thread, one run at a time. The quick sweep takes ~6 min; --defaults adds
# the two apps' defaults at their own spacings (~2 min more; the charts in docs/); PARETO_FLAGS=--full enlarges it.
PARETO_FLAGS ?= --defaults
bench-pareto: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target poiseuille rotating
	OMP_NUM_THREADS=1 /usr/bin/python3 bench/pareto.py build/release $(PARETO_FLAGS) --results $(RESULTS)

# Per-step cost by phase against N: the body-force channel scaled up (as long as it is wide), each backend for 10
# steps after 3, the classic baseline (IC-CG from a zero initial guess) included, and hypre-pcg at a looser tolerance
# (its profile error is the same to four digits at 3e5); one thread.
SCALING_SIZES ?= 1e4,3e4,1e5,3e5,1e6
SCALING_SOLVERS ?= eigen-cg;eigen-cg:precond=jacobi;hypre-pcg:reuse=10;hypre-pcg:reuse=10,tol=1e-6;cholmod
SCALING_OUT ?= $(RESULTS)
bench-scaling: deps build/release/CMakeCache.txt
	cmake --build build/release -j$(JOBS) --target bench_scaling
	OMP_NUM_THREADS=1 ./build/release/bench/bench_scaling --sizes $(SCALING_SIZES) --solvers "$(SCALING_SOLVERS)" \
	  --cold eigen-cg --warmup 3 --steps 10 --out $(SCALING_OUT)/scaling.csv
	/usr/bin/python3 bench/plot_scaling.py $(SCALING_OUT)/scaling.csv $(SCALING_OUT)/scaling.png

# Stability maps (design section 7): gamma x dt factor, each run classified as stable / inaccurate / blown up, for the
# inlet channel at Re 400 (20 across, 4 D, to 2 D/U) and the screw channel (16 across, to 0.5 s); one thread, one run
# at a time. CSV + PNG in bench/results/stability_{inlet,channel}.*
bench-stability: deps build/release/CMakeCache.txt
	cmake --build build/release -j1 --target poiseuille rotating
	OMP_NUM_THREADS=1 /usr/bin/python3 bench/stability_maps.py build/release --results $(RESULTS)

clean:
	rm -rf build runs
