#!/usr/bin/python3
"""The summary keys renamed by issue 26 (one naming rule, docs/config-files.md), old path -> new path, and a
check that two records of scripts/compare_results.py differ by exactly these renames.

  scripts/summary_renames.py table                       # the renames, as the Markdown table of docs/config-files.md
  scripts/summary_renames.py upgrade OLD/summary.json    # an old summary with its keys renamed, on stdout
  scripts/summary_renames.py check BEFORE.json AFTER.json
      # records of compare_results.py made before and after the renames: every old summary, renamed, must equal the
      # new one value for value (bitwise: JSON numbers compare as the same doubles), and every other file, frames
      # included, must be the same. Exit 1 and list what differs otherwise.

A path is keys joined by "/"; "*" stands for every item of a list.
"""
import copy
import json
import sys

COMMON = [
    ("particle_steps_per_second", "particle_steps_per_s"),
    ("timings/particle_steps_per_second", "timings/particle_steps_per_s"),
    ("parameters/rho", "parameters/rho_kg_per_m3"),
    ("parameters/nu", "parameters/nu_m2_per_s"),
    ("parameters/g", "parameters/g_m_per_s2"),
    ("parameters/Re", "parameters/re"),
    ("parameters/particles_across", "parameters/across"),
    ("parameters/radii_l0/density", "parameters/radii/density_l0"),
    ("parameters/radii_l0/surface", "parameters/radii/surface_l0"),
    ("parameters/radii_l0/gradient", "parameters/radii/gradient_l0"),
    ("parameters/radii_l0/laplacian", "parameters/radii/laplacian_l0"),
    ("parameters/version", None),  # the same as run/version
]
RENAMES = {
    "poiseuille": [
        ("parameters/l0_m", "parameters/dx_m"),
        ("parameters/D_m", "parameters/width_m"),
        ("parameters/U_m_per_s", "parameters/velocity_scale_m_per_s"),
        ("parameters/length/periodic_length_l0", "parameters/length_l0"),
        ("parameters/length/length_D", "parameters/channel_length_D"),
        ("parameters/length/station_D", "parameters/station_D"),
        ("parameters/profile_average_D_over_U", "parameters/average_D_over_U"),
    ],
    "hydrostatic": [
        ("parameters/l0_m", "parameters/dx_m"),
        ("parameters/water_height_m", "parameters/height_m"),
        ("parameters/dt_max_s", "parameters/dt_s"),
        ("checks/max_band_pressure_error_below_top", "checks/max_band_pressure_error"),
    ],
    "rotating": [
        ("parameters/R1", "parameters/inner_radius_m"),
        ("parameters/R2", "parameters/outer_radius_m"),
        ("parameters/U_scale", "parameters/velocity_scale_m_per_s"),
        ("parameters/l0", "parameters/dx_m"),
        ("parameters/sample_times_s", "parameters/times_s"),
        ("checks/arc2_odd_defect", "checks/arc2_odd_defect_over_omega_R2"),
        ("checks/arc2_odd_defect_full_span", "checks/arc2_odd_defect_full_span_over_omega_R2"),
        ("checks/barrel_pressure_range_abs_phi_le_0.4", "checks/barrel_pressure_range_pa"),
        ("checks/escaped_fluid_particles_max", "checks/max_escaped_fluid_particles"),
    ],
    "acoustic": [
        ("parameters/c0_m_s", "parameters/c0_m_per_s"),
        ("parameters/rho0_kg_m3", "parameters/rho0_kg_per_m3"),
        ("parameters/u0_m_s", "parameters/u0_m_per_s"),
        ("parameters/pulse/half_width_m", "parameters/pulse/b_m"),
        ("parameters/repetition_hz", "parameters/frequency_hz"),
        ("parameters/quadrature_tolerance_eps", "parameters/tolerance_over_eps"),
        ("parameters/guard_energy_factor", "parameters/guard_factor"),
        ("gradient_nnz", "gradient_nonzeros"),
        ("stable_cfl_estimate", "stable_cfl"),
        ("samples/*/exact_energy_fraction_in_box", "samples/*/exact_in_box_energy_fraction"),
        ("timings/spmv_samples", "timings/spmv_sample_count"),
    ],
    "dambreak": [
        ("parameters/level_probes_H_from_downstream_wall", "parameters/level_probes_from_downstream_wall_H"),
        ("checks/front_compared_up_to_T", "checks/front_compared_up_to_t_sqrt_2g_over_a"),
        ("checks/front_max_error_martin_moyce_1", "checks/martin_moyce_1_front_max_error"),
        ("checks/front_max_error_martin_moyce_2", "checks/martin_moyce_2_front_max_error"),
        ("checks/front_max_error_koshizuka_oka", "checks/koshizuka_oka_front_max_error"),
        ("checks/impact_0.2H", "checks/impact"),  # the probe's height moves into the value: impact/probe_H = 0.2
        ("checks/impact/arrival", "checks/impact/arrival_t_sqrt_g_over_H"),
        ("checks/impact/arrival_buchner", "checks/impact/arrival_buchner_t_sqrt_g_over_H"),
        ("checks/impact/first_peak", "checks/impact/first_peak_over_rho_g_H"),
        ("checks/impact/first_peak_buchner", "checks/impact/first_peak_buchner_over_rho_g_H"),
        ("checks/impact/noise", "checks/impact/noise_over_range"),
        ("checks/impact/noise_buchner", "checks/impact/noise_buchner_over_range"),
        ("checks/fluid_removed_as_spray", "checks/fluid_removed_as_spray_count"),
        ("checks/most_fluid_inside_walls", "checks/most_fluid_inside_walls_count"),
    ],
    "structure": [
        ("parameters/density", "parameters/density_kg_per_m3"),
        ("parameters/youngs_modulus_pa", "parameters/modulus_pa"),
        ("parameters/poisson_ratio", "parameters/poisson"),
        ("parameters/radius_dx", "parameters/radius_l0"),
        ("parameters/stable_cfl_estimate", "parameters/stable_cfl"),
        ("parameters/p_wave_speed_m_s", "parameters/p_wave_speed_m_per_s"),
        ("parameters/gravity", "parameters/gravity_m_per_s2"),
        ("parameters/probe", "parameters/probe_m"),
        ("checks/energy_drift", "checks/energy_drift_fraction"),
        ("checks/uy/minima", "checks/uy/minima_count"),
        ("checks/ux/minima", "checks/ux/minima_count"),
        ("checks/uy_reference/minima", "checks/uy_reference/minima_count"),
        ("checks/ux_reference/minima", "checks/ux_reference/minima_count"),
        ("timings/steps_per_second", "timings/steps_per_s"),
        ("timings/spmv_equivalents_per_step", "timings/per_step_spmv_equivalents"),
    ],
    "fsi": [
        ("parameters/youngs_modulus_pa", "parameters/modulus_pa"),
        ("parameters/poisson_ratio", "parameters/poisson"),
        ("parameters/body_density", "parameters/density_kg_per_m3"),
        ("parameters/load_relaxation", "parameters/relaxation"),
        ("checks/at_s", "checks/largest_probe_ux_at_s"),
    ],
}
# Keys added with a value the old summary held in a key's name: (app, path, value), set where the parent exists.
ADDED = [("dambreak", "checks/impact/probe_H", 0.2)]


def _paths(node, keys, at=()):
    """The concrete paths (keys and list indices) that `keys` reaches in node, "*" spreading over lists."""
    if not keys:
        return [at]
    head, rest = keys[0], keys[1:]
    if head == "*":
        return [p for i, item in enumerate(node) for p in _paths(item, rest, at + (i,))] if isinstance(node, list) else []
    return _paths(node[head], rest, at + (head,)) if isinstance(node, dict) and head in node else []


def _get(node, path):
    for k in path:
        node = node[k]
    return node


def upgrade(summary, app):
    """The old summary of `app` with its keys renamed (and emptied objects, such as radii_l0, dropped)."""
    new = copy.deepcopy(summary)
    for old_path, new_path in COMMON + RENAMES.get(app, []):
        old_keys = old_path.split("/")
        for path in _paths(new, old_keys):
            value = _get(new, path[:-1]).pop(path[-1])
            if new_path is not None:
                # The list indices where the old path had "*" go where the new one has it.
                indices = iter(k for k, pattern in zip(path, old_keys) if pattern == "*")
                target = new
                new_keys = [next(indices) if k == "*" else k for k in new_path.split("/")]
                for k in new_keys[:-1]:
                    target = target.setdefault(k, {}) if isinstance(k, str) else target[k]
                target[new_keys[-1]] = value
            for depth in range(len(path) - 1, 0, -1):
                parent = _get(new, path[:depth - 1])
                if isinstance(parent, dict) and parent.get(path[depth - 1]) == {}:
                    del parent[path[depth - 1]]
    for added_app, added, value in ADDED:
        keys = added.split("/")
        if added_app == app:
            for path in _paths(new, keys[:-1]):
                _get(new, path)[keys[-1]] = value
    return new


def table():
    rows = ["| app | old key | new key |", "| --- | --- | --- |"]
    removed = "(removed: `run/version` holds it)"
    rows += [f"| any that has it | `{o}` | {f'`{n}`' if n else removed} |" for o, n in COMMON]
    for app, renames in RENAMES.items():
        rows += [f"| {app} | `{o}` | `{n}` |" for o, n in renames]
    rows += [f"| {app} | | `{path}` (added: {value}) |" for app, path, value in ADDED]
    return "\n".join(rows)


def check(before_file, after_file):
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from compare_results import CASES, differences
    before, after = json.loads(open(before_file).read()), json.loads(open(after_file).read())
    problems = []
    for name, (app, _) in CASES.items():
        old, new = before.get(name), after.get(name)
        if old is None or new is None:
            problems.append(f"{name}: not in both records")
            continue
        renamed = copy.deepcopy(old)
        if "summary" in renamed:
            renamed["summary"] = upgrade(renamed["summary"], app)
        for rel, content in renamed["files"].items():  # the summaries of rotating --model both's models
            if rel.endswith("summary.json") and isinstance(content, dict):
                renamed["files"][rel] = upgrade(content, app)
        found = [f"{name}{d}" for d in differences("", renamed, new)]
        print(f"{name}: {'the same but for the renames' if not found else 'DIFFERS'}", flush=True)
        problems += found
    for p in problems:
        print("DIFF", p)
    print(f"{len(CASES)} cases: " + ("every difference is a listed rename" if not problems else f"{len(problems)} differences"))
    return 1 if problems else 0


def main():
    if sys.argv[1:2] == ["table"] and len(sys.argv) == 2:
        print(table())
        return 0
    if sys.argv[1:2] == ["upgrade"] and len(sys.argv) == 3:
        summary = json.loads(open(sys.argv[2]).read())
        print(json.dumps(upgrade(summary, summary.get("run", {}).get("app", "")), indent=2, sort_keys=True))
        return 0
    if sys.argv[1:2] == ["check"] and len(sys.argv) == 4:
        return check(sys.argv[2], sys.argv[3])
    print(__doc__.strip(), file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
