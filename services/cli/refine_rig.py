"""``gaitcap refine-rig TRIAL... --calibration CALIB --out NEW.toml``: refine a calibration from the people
filmed in trials (bundle adjustment of the camera poses, the given calibration as prior and its scale kept),
and say how far each camera moved (``--moved CAM``: only those cameras adjusted); ``--check`` only checks the rig
against each trial (moved cameras), with ``--baseline TRIAL`` against a trial recorded with the calibration as is.
With ``--data-dir``/``--catalog`` the trials may be named by id and the refined calibration is stored as a
new calibration version replacing ``--replaces`` (default: the active calibration), its prior unless
``--calibration`` is given; ``gaitcap apply-calibration`` then reprocesses the trials that used the old one."""

from __future__ import annotations

import json
import logging
from dataclasses import replace
from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors

log = logging.getLogger(__name__)


def _patient(path: Path, rig):
    """The patient's detections of one trial (a trial .mcap or a keypoint folder another tool wrote),
    aligned to ``rig``."""
    from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
    from gaitcap.services.processing.pipeline import patient_input, resolve_layout

    data = read_keypoints_input(path, rig=rig)
    missing = [n for n in data.recording.camera_names if n not in rig.names]
    if missing:
        raise ValueError(f"{path}: cameras {missing} are not in the calibration (it has {list(rig.names)})")
    recording, _ = resolve_layout(data.recording, rig, named=data.layout)
    det, _, _ = patient_input(recording, rig)
    return det


def _check_table(name: str, check) -> str:
    lines = [f"{name}: " + ("cameras moved: " + ", ".join(check.moved) if check.flagged else "no camera moved"),
             f"  {'camera':<10} {'points':>6} {'error px':>9} {'refit px':>9} {'field px':>9} {'+-':>5} "
             f"{'rot deg':>8} {'+- deg':>6} {'shift mm':>9} {'+- mm':>6}  moved"]
    for c in check.cameras:
        lines.append(f"  {c.name:<10} {c.points:>6} {c.residual_px:>9.2f} {c.refit_residual_px:>9.2f} "
                     f"{c.field_px:>9.2f} {c.field_se_px:>5.2f} {c.rotation_deg:>8.2f} {max(c.rotation_bound_deg):>6.2f} "
                     f"{c.shift_mm:>9.1f} {c.shift_bound_mm:>6.0f}  {'YES' if c.moved else 'no'}")
    return "\n".join(lines + [f"  {w}" for w in check.warnings])


def _refine_table(report) -> str:
    lines = [f"{report.trials} trial(s), {report.frames} frames, {report.keypoints} keypoints "
             f"({report.outliers} rejected as outliers or swaps); median error {report.median_before_px:.2f} px "
             f"-> {report.median_after_px:.2f} px in {report.solve_time_s:.1f} s",
             f"{'camera':<10} {'before px':>10} {'after px':>9} {'centre mm':>10} {'rotation deg':>13} {'focal %':>8}"]
    for c in report.comparison.cameras:
        lines.append(f"{c.name:<10} {report.per_camera_before_px[c.name]:>10.2f} {report.per_camera_after_px[c.name]:>9.2f} "
                     f"{c.centre_mm:>10.2f} {c.rotation_deg:>13.3f} {c.focal_pct:>+8.3f}")
    return "\n".join(lines)


def open_existing_catalog(data_dir: Path | None, catalog: str):
    """The catalog of ``data_dir`` (or ``catalog``, a path or URL); ValueError naming a SQLite file that does
    not exist (never a new, empty catalog)."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.catalog.paths import catalog_url

    url = catalog_url(data_dir or Path("."), catalog or None)
    if "://" not in url and not Path(url).is_file():
        raise ValueError(f"catalog {url} does not exist (--data-dir / --catalog)")
    return cat.open_catalog(url)


def _trial_paths(db, trials: list[Path]) -> list[Path]:
    """Each argument as a recording: a file or folder as given, else (with a catalog) a trial id whose
    recording the catalog records; ValueError naming an argument that is neither."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.processing.worker import recording_of

    out = []
    for arg in trials:
        if arg.exists() or db is None:
            out.append(arg)
            continue
        try:
            out.append(recording_of(cat.get_trial(db, str(arg))))
        except cat.TrialNotFound:
            raise ValueError(f"{arg}: neither a file or folder nor a trial in the catalog") from None
    return out


def _prior(db, calibration: Path | None, replaces: str | None):
    """(rig, id it replaces or None): ``--calibration`` if given, else the catalog's calibration it replaces."""
    from gaitcap.acquisition.importers.tool_folders import load_calibration
    from gaitcap.reconstruction.calibration_io import rig_from_toml_text
    from gaitcap.services import catalog as cat

    if db is None:
        if calibration is None:
            raise ValueError("--calibration: give the calibration in use (or --data-dir/--catalog to take it from "
                             "the catalog)")
        if replaces is not None:
            raise ValueError("--replaces: needs the catalog (--data-dir or --catalog)")
        return load_calibration(calibration), None
    if replaces is None:
        active = cat.latest_calibration(db)
        if active is None:
            raise ValueError("the catalog holds no calibration to replace (upload or record one first)")
        replaces = active[0]
    if calibration is not None:
        return load_calibration(calibration), replaces
    return rig_from_toml_text(cat.calibration_toml(db, replaces), source=f"calibration {replaces}"), replaces


def _store_version(db, rig, report, replaces: str, trials: list[Path]) -> str:
    """The refined rig as a new calibration version replacing ``replaces``; echoes what to do next."""
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text
    from gaitcap.services.catalog.calibration_versions import add_version, trials_using

    comparison = {c.name: {"centre_mm": c.centre_mm, "rotation_deg": c.rotation_deg, "focal_pct": c.focal_pct}
                  for c in report.comparison.cameras}
    new_id = add_version(db, toml=rig_to_toml_text(rig), replaces_id=replaces, made_by="refine-rig",
                         trials=[str(t) for t in trials], comparison=comparison, report=report.to_dict())
    affected = trials_using(db, replaces)
    typer.echo(f"stored calibration {new_id} replacing {replaces} (active for later trials); "
               f"{len(affected)} trial(s) used {replaces}: `gaitcap apply-calibration {new_id}` reprocesses them")
    return new_id


def _from_people(dets, rig, height_mm: float, max_frames: int | None):
    from gaitcap.reconstruction.calibration.people_init import PeopleCalibrationConfig, calibrate_from_people

    if len(dets) != 1:
        raise ValueError(f"--height-mm: calibrating from people alone takes one walk, got {len(dets)} trials")
    config = PeopleCalibrationConfig()
    if max_frames is not None:
        config = replace(config, bundle=replace(config.bundle, max_frames=max_frames))
    return calibrate_from_people(dets[0][1], rig, height_mm=height_mm, config=config)


def register(app: typer.Typer) -> None:
    @app.command("refine-rig")
    def refine_rig_cmd(
        trials: list[Path] = typer.Argument(..., help="Trials: trial .mcap recordings or keypoint folders (OpenPose JSON, Pose2Sim)."),
        calibration: Path | None = typer.Option(None, "--calibration", help="The calibration in use (the prior): .toml, .json or .qca.txt (with a catalog: default the one replaced)."),
        out: Path | None = typer.Option(None, "--out", help="Refined calibration to write (.toml or .json); its report beside it (.report.json)."),
        focal: bool = typer.Option(False, "--focal", help="Also refine each camera's focal length."),
        check: bool = typer.Option(False, "--check", help="Only check the rig against each trial (which camera moved, by how much); write nothing."),
        baseline: Path | None = typer.Option(None, "--baseline", help="With --check: a trial recorded with the calibration as is (e.g. the session's static trial); each camera is judged by the change of its field since it."),
        moved: list[str] = typer.Option([], "--moved", help="Adjust only this camera (repeat for several; e.g. the ones --check flagged); every other camera keeps its calibration exactly."),
        max_frames: int | None = typer.Option(None, "--max-frames", help="Frames used at most per trial (default 150; with --height-mm 400)."),
        height_mm: float | None = typer.Option(None, "--height-mm", help="Calibrate from people alone (no board): the subject's standing height, mm, sets the scale; only the calibration's intrinsics are used (one trial: a walk)."),
        data_dir: Path | None = typer.Option(None, "--data-dir", envvar="GAITCAP_DATA_DIR", help="Store the refined calibration in this data folder's catalog as a new version (trials may then be named by id)."),
        catalog: str = typer.Option("", "--catalog", envvar="GAITCAP_CATALOG", help="SQLite path or SQLAlchemy URL (default DATA_DIR/catalog.sqlite)."),
        replaces: str | None = typer.Option(None, "--replaces", help="With a catalog: the calibration id the new version replaces (default: the active one)."),
    ) -> None:
        """Refine a calibration from the people in trials, or check the rig against them (--check)."""
        from gaitcap.acquisition.fileio import atomic_write_text
        from gaitcap.acquisition.writers import save_rig
        from gaitcap.reconstruction.calibration.people_bundle import (
            PeopleBundleConfig,
            refine_rig_from_people,
        )
        from gaitcap.reconstruction.calibration.rig_check import check_rig
        from gaitcap.reconstruction.triangulation import robust_triangulate

        with user_errors():
            db = open_existing_catalog(data_dir, catalog) if data_dir is not None or catalog else None
            if not check and out is None and (db is None or height_mm is not None):
                raise ValueError("--out: give the refined calibration's file name (or --check to only check)")
            if out is not None and out.suffix.lower() not in (".toml", ".json"):
                raise ValueError(f"--out {out}: use a .toml or .json file name")
            rig, replaced = _prior(db, calibration, replaces)
            dets = [(path, _patient(path, rig)) for path in _trial_paths(db, trials)]
            if baseline is not None and not check:
                raise ValueError("--baseline: only with --check")
            if check:
                reference = _patient(baseline, rig) if baseline is not None else None
                for path, det in dets:
                    sub = rig.subset(det.camera_names)
                    result = check_rig(det, sub, robust_triangulate(det, sub).points_mm, baseline=reference)
                    typer.echo(_check_table(str(path), result))
                return
            if height_mm is not None:
                result = _from_people(dets, rig, height_mm, max_frames)
                save_rig(result.rig, out, metadata={"calibrated_from": str(trials[0]), "height_mm": height_mm})
                report_file = out.with_suffix(".report.json")
                atomic_write_text(report_file, json.dumps(result.to_dict(), indent=2))
                typer.echo(f"from people alone: stature {result.stature_mm:.0f} mm (entered {height_mm:.0f} mm)")
                typer.echo(_refine_table(result.report))
                typer.echo(f"wrote {out} and {report_file}")
                return
            result = refine_rig_from_people([d for _, d in dets], rig, moved=moved or None,
                                            config=PeopleBundleConfig(refine_focal=focal, max_frames=max_frames or 150))
            typer.echo(_refine_table(result.report))
            if db is not None:
                _store_version(db, result.rig, result.report, replaced, trials)
            if out is not None:
                save_rig(result.rig, out, metadata={"refined_from": [str(p) for p in trials],
                                                    "prior": str(calibration or replaced)})
                report_file = out.with_suffix(".report.json")
                atomic_write_text(report_file, json.dumps(result.report.to_dict(), indent=2))
                typer.echo(f"wrote {out} and {report_file}")
