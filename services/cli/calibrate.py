"""``gaitcap calibrate RECORDING.mcap|FOLDER [--board checkerboard|charuco ...] --out CALIB.toml``."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors
from gaitcap.services.cli.board import (
    BOARD_FILE,
    DICTIONARY,
    INVERTED,
    KIND,
    LEGACY,
    MARKER_MM,
    SQUARE_MM,
    SQUARES,
    board_from_options,
)


def _summary(report) -> str:
    lines = [f"{'camera':<10} {'views':>6} {'kept':>5} {'corners':>8} {'RMS px':>7} {'median':>7} {'p95 px':>7} "
             f"{'coverage':>9}  status"]
    for q in report.cameras:
        status = ("ok" if q.ok else "FAILED: " + "; ".join(q.problems)) + "".join(f" | note: {n}" for n in q.notes)
        lines.append(
            f"{q.name:<10} {q.n_detections:>6} {100 * q.views_kept_fraction:>4.0f}% {q.n_corners:>8} "
            f"{q.reprojection_rms_px:>7.3f} {q.median_px:>7.3f} {q.reprojection_p95_px:>7.3f} "
            f"{100 * q.coverage:>8.0f}%  {status}"
        )
    lines.append(
        f"reprojection RMS {report.reprojection_rms_px:.3f} px, p95 {report.reprojection_p95_px:.3f} px; "
        f"square {report.square_measured_mm:.2f} mm measured vs {report.square_mm:g} mm "
        f"({report.square_residual_pct:+.2f} %); {report.n_outliers} outlier corners; "
        f"world from {report.floor_frames} floor frame(s){' (turned over)' if report.world_flipped else ''}"
    )
    if report.board_check is not None:
        lines.append(f"board in 3D after the fit: {_board_line(report.board_check)}")
    lines += [f"PROBLEM: {p}" for p in report.board_problems]
    if report.outlier_corners:
        named = "; ".join(f"{cam} frames {', '.join(str(v['frame']) for v in views)}"
                          for cam, views in report.outlier_corners.items())
        lines.append(f"outlier corners (beyond {report.outlier_threshold_px:.2f} px) dropped in: {named} "
                     "(each corner in the report's outlier_corners)")
    return "\n".join(lines)


def _board_line(board: dict) -> str:
    return (f"square {board['square_mm']:.2f} mm (columns {board['square_cols_mm']:.2f}, rows "
            f"{board['square_rows_mm']:.2f}) vs {board['described_square_mm']:g} mm, square error RMS "
            f"{board['square_error_rms_mm']:.2f} mm, flatness RMS {board['flatness_rms_mm']:.2f} mm, shape RMS "
            f"{board['shape_rms_mm']:.2f} mm over {board['frames']} frame sets")


def _held_out(cmp) -> str:
    """The held-out table: per camera this calibration's figures and, on the same frame sets, the reference's
    (made from every frame set) and another tool's calibration fitted per fold (``--caliscope-folds``)."""
    own, ref, other = cmp.own, cmp.reference, cmp.refitted
    head = (f"held-out error ({own.folds} folds in time, {own.frame_sets} frame sets judged; fits {own.seconds:.0f} s): "
            "reprojection RMS over all held-out corners / inliers (px), 3D square error (mm)")
    cols = [("reference", ref), ("caliscope per fold", other)]
    lines = [head, f"{'camera':<10} {'views':>6} {'RMS px':>7} {'inlier':>7} {'sq mm':>6}"
             + "".join(f"  | {who}: {'RMS px':>7} {'inlier':>7} {'sq mm':>6}" for who, e in cols if e is not None)]
    for c in own.cameras:
        row = f"{c.name:<10} {c.views_judged:>6} {c.rms_px:>7.3f} {c.rms_inlier_px:>7.3f} {c.square_error_rms_mm:>6.2f}"
        for who, e in cols:
            if e is not None:
                r = e.camera(c.name)
                row += f"  | {'':>{len(who) + 1}} {r.rms_px:>7.3f} {r.rms_inlier_px:>7.3f} {r.square_error_rms_mm:>6.2f}"
        lines.append(row)
    lines.append(f"rig: RMS {own.rms_px:.3f} px; board in 3D: {_board_line(_board_dict(own.board))}")
    if ref is not None:
        lines.append(f"{ref.label} on the same frame sets (if it was made from this recording, they are in-sample for it): RMS "
                     f"{ref.rms_px:.3f} px; board in 3D: {_board_line(_board_dict(ref.board))}")
    if other is not None:
        lines.append(f"{other.label}, fitted on each fold's frame sets as this calibration is (held out for it too): "
                     f"RMS {other.rms_px:.3f} px; board in 3D: {_board_line(_board_dict(other.board))}")
    lines += [f"fold not fitted: {e}" for e in own.fold_errors]
    lines += [f"PROBLEM ({e.label}): {p}" for e in (own, ref, other) if e is not None for p in e.problems]
    return "\n".join(lines)


def _board_dict(board) -> dict:
    from dataclasses import asdict

    return asdict(board)


def _choice(choice) -> str:
    lines = [f"intrinsics chosen per camera by held-out error ({choice.folds} folds in time, {len(choice.candidates)} "
             f"candidates, {choice.seconds:.0f} s): held-out RMS px per candidate"]
    lines += [f"  {i + 1}: {label}" for i, label in enumerate(choice.candidates)]
    for cam, rms in choice.held_out_rms_px.items():
        lines.append(f"{cam:<10} " + " ".join(f"{r:>6.3f}" for r in rms) + f"  -> {choice.chosen[cam]}")
    if choice.rig_rms_px:
        lines.append(f"{'rig':<10} " + " ".join(f"{r:>6.3f}" for r in choice.rig_rms_px)
                     + f"  -> {choice.combined_rms_px:.3f} with the intrinsics chosen")
    lines += [f"candidate {k} not fitted in every fold: {v[0]}" for k, v in choice.failures.items()]
    lines += [choice.fallback] if choice.fallback else []
    lines += [choice.shared_focal] if choice.shared_focal else []
    return "\n".join(lines)


def _fit_choice(fit) -> str:
    lines = [f"fit chosen by held-out error ({fit.folds} folds in time, {len(fit.candidates)} candidates, "
             f"{fit.seconds:.0f} s): rig RMS px per candidate"]
    for label, rms in zip(fit.candidates, fit.rig_rms_px, strict=True):
        lines.append(f"  {label}: {rms:.3f}" + ("  <- chosen" if label == fit.chosen else ""))
    lines += [f"candidate {k} not fitted in every fold: {v[0]}" for k, v in fit.failures.items()]
    return "\n".join(lines)


def _comparison(cmp) -> str:
    lines = [f"{'camera':<10} {'centre mm':>10} {'rotation deg':>13} {'focal %':>8} {'rig shape mm':>13}"]
    for c in cmp.cameras:
        lines.append(f"{c.name:<10} {c.centre_mm:>10.2f} {c.rotation_deg:>13.3f} {c.focal_pct:>+8.3f} "
                     f"{c.aligned_centre_mm:>13.2f}")
    lines.append(f"max: centre {cmp.centre_mm_max:.2f} mm, rotation {cmp.rotation_deg_max:.3f} deg, rig shape "
                 f"{cmp.aligned_centre_mm_max:.2f} mm; world frame: tilt {cmp.world_tilt_deg:.3f} deg, heading "
                 f"{cmp.world_heading_deg:.3f} deg, shift {cmp.world_shift_mm:.2f} mm")
    return "\n".join(lines)


def _similar(cmp) -> str:
    per = ", ".join(f"{n} {c:.1f} mm {r:.2f} deg" for n, c, r in zip(cmp.names, cmp.centre_mm, cmp.rotation_deg,
                                                                    strict=True))
    return (f"after a similarity alignment (scale {cmp.scale:.4f}): centres max {cmp.centre_mm_max:.2f} mm, "
            f"rotations max {cmp.rotation_deg_max:.3f} deg ({per})")


APART_MM, APART_DEG = 15.0, 1.0  # rigs this far apart (after a similarity alignment) differ in substance


def _which_is_right(similar, held_out) -> str:
    """Where this rig and the --compare one differ by more than APART_MM or APART_DEG: which one the
    held-out error favours, on equal terms when caliscope's calibration was fitted per fold
    (``--caliscope-folds``), else against the reference as given (in-sample for it if made from this
    recording, which the line says)."""
    if similar.centre_mm_max <= APART_MM and similar.rotation_deg_max <= APART_DEG:
        return ""
    head = (f"the rigs differ by {similar.centre_mm_max:.1f} mm / {similar.rotation_deg_max:.2f} deg (more than "
            f"{APART_MM:g} mm or {APART_DEG:g} deg): ")
    if held_out is None or isinstance(held_out, str):
        return head + "measure the held-out error (--folds K, --caliscope-folds) to tell which is right"
    own, other = held_out.own, held_out.refitted or held_out.reference
    if other is None:
        return head + "give the reference's cameras to judge it on the same held-out frame sets"
    better = "this calibration" if own.rms_px <= other.rms_px else other.label
    how = ("both fitted on each fold, judged on the same held-out frame sets" if held_out.refitted is not None
           else "the reference judged on the same frame sets, in-sample for it if made from this recording")
    return head + f"the held-out error favours {better} ({own.rms_px:.3f} against {other.rms_px:.3f} px; {how})"


def _stereo(diff, first: str, second: str) -> str:
    return (f"the pair's own geometry ({second} seen from {first}): baseline {diff.baseline_mm:.2f} mm vs "
            f"{diff.reference_baseline_mm:.2f} mm in the reference; {second}'s centre {diff.centre_mm:.2f} mm and "
            f"its rotation {diff.rotation_deg:.3f} deg from the reference's")


def _load_calibration(path: Path):
    """A calibration file: caliscope's camera_array.toml, or any other gaitcap reads (Qualisys .qca.txt,
    Pose2Sim/aniposelib .toml, gaitcap .json)."""
    from gaitcap.acquisition.importers.caliscope import is_camera_array, read_camera_array
    from gaitcap.acquisition.importers.tool_folders import load_calibration

    return read_camera_array(path) if is_camera_array(path) else load_calibration(path)


def _views(recording: Path, cfg, flags_given: bool, selection, pairing, progress_bar):
    """Board observations and a line (or table) on what was found: a recording, or a caliscope session
    folder (its corner detections; its board unless one is given)."""
    from gaitcap.acquisition.boards.recording import find_board_views
    from gaitcap.acquisition.importers.caliscope import is_session, read_session

    if is_session(recording):
        if selection.max_frames is not None:
            raise ValueError("--max-frames: a caliscope session holds corner detections, not frames to search; "
                             "use --every N to keep every N-th of its frame sets")
        board, obs, _, moving = read_session(recording, pairing=pairing, board=cfg if flags_given else None,
                                             sync_every=selection.every)
        counts = ", ".join(f"{n} {k}" for n, k in zip(obs.camera_names, obs.views().sum(1).tolist(), strict=True))
        every = f" (every {selection.every}th frame set)" if selection.every > 1 else ""
        return board, obs, None, f"caliscope session{every}: views {counts}; {moving} left out (board moving)"
    found = find_board_views(recording, board=cfg, selection=selection, pairing=pairing, progress=progress_bar)
    obs = found.observations
    return cfg, obs, found, (f"{int(obs.views().sum())} views in {obs.shape[1]} frame sets (paired "
                             f"{'by time' if found.timed else 'by order'})\n{found.table()}")


def _cross_validate(obs, config, folds: int, reference, reference_path: Path | None, refit=None,
                    refit_label: str = ""):
    """The held-out comparison (this calibration's folds, the reference on the same frame sets, ``refit``:
    another tool's calibration fitted on each fold's frame sets), or a line saying why it could not be
    measured (the calibration itself stands). The judge is the default bundle adjustment's board-pose fit,
    whatever loss the calibration was fitted with."""
    from gaitcap.reconstruction.calibration import calibrate_from_observations
    from gaitcap.reconstruction.calibration.holdout import HoldoutConfig, cross_validate

    if reference is not None and any(n not in reference.names for n in obs.camera_names):
        reference = None  # another rig: judged on its own cameras only by --compare
    try:
        with progress(total=folds, desc="held-out folds", unit="fold") as bar:
            return cross_validate(obs, lambda o: calibrate_from_observations(o, config=config).rig,
                                  reference=reference, reference_label=f"reference {reference_path}",
                                  config=HoldoutConfig(folds=folds), refit=refit, refit_label=refit_label,
                                  progress=lambda done, total: bar.update(1))
    except ValueError as exc:
        return f"held-out error not measured: {exc}"


def _caliscope_refit(mode: str | None, known, reference):
    """(``refit``, label) for ``--caliscope-folds``: caliscope's own calibration of each fold's frame sets,
    with the given intrinsics (``--intrinsics``, else the ``--compare`` calibration's) or from the clip."""
    if mode is None:
        return None, ""
    from gaitcap.acquisition.importers.caliscope import calibrate_with_caliscope, caliscope_available

    if mode not in ("given", "clip"):
        raise ValueError(f"--caliscope-folds: given (caliscope starts from the --intrinsics, else the --compare "
                         f"calibration's intrinsics) or clip (its own intrinsic calibration from these views), got {mode!r}")
    if not caliscope_available():
        raise ValueError("--caliscope-folds needs caliscope's scripting API: pip install -e '.[caliscope]' in "
                         "gaitcap's checkout")
    if mode == "clip":
        return (lambda o: calibrate_with_caliscope(o)), "caliscope's calibration (intrinsics from the clip)"
    given = known if known is not None else reference
    if given is None:
        raise ValueError("--caliscope-folds given: give the intrinsics (--intrinsics, or --compare caliscope's "
                         "camera_array.toml)")
    return (lambda o: calibrate_with_caliscope(o, given)), "caliscope's calibration (intrinsics given)"


def register(app: typer.Typer) -> None:
    @app.command("calibrate")
    def calibrate_cmd(
        recording: Path = typer.Argument(..., help="Board recording: a trial .mcap, a folder with <camera>/ images or <camera>.mp4 videos (and a timestamps.csv), or a caliscope session folder."),
        out: Path = typer.Option(..., "--out", help="Calibration to write (.toml aniposelib/Pose2Sim, or .json gaitcap)."),
        board_file: Path | None = BOARD_FILE, board: str | None = KIND, squares: str | None = SQUARES,
        square_mm: float | None = SQUARE_MM, marker_mm: float | None = MARKER_MM,
        dictionary: str | None = DICTIONARY, inverted: bool | None = INVERTED, legacy: bool | None = LEGACY,
        distortion: str = typer.Option("k1", "--distortion", help="Distortion terms: k1 (the paper's) | k1k2 | k1k2p1p2k3."),
        every: int = typer.Option(1, "--every", help="Use every N-th frame."),
        max_frames: int | None = typer.Option(None, "--max-frames", help="Use at most this many frames."),
        floor_frame: int | None = typer.Option(None, "--floor-frame", help="Index, among the frames where the board was found, of one with the board on the floor (default 0)."),
        report_path: Path | None = typer.Option(None, "--report", help="Quality report JSON (default: OUT with .report.json)."),
        compare: Path | None = typer.Option(None, "--compare", help="A reference calibration (the last one, or a simulation's truth) to compare the new one with."),
        intrinsics: Path | None = typer.Option(None, "--intrinsics", help="Keep these cameras' intrinsics (a calibration: .toml, .json, .qca.txt or caliscope's camera_array.toml, e.g. from a separate intrinsics session); estimate only the poses."),
        sync_tolerance_ms: float | None = typer.Option(None, "--sync-tolerance-ms", help="Pair frames of different cameras closer than this in time (default: half a frame interval)."),
        readout_ms: float = typer.Option(0.0, "--readout-ms", help="Rolling-shutter readout of the cameras, ms (webcams: about 20): views whose board moved more than 1 px meanwhile tie no cameras together."),
        accept_failed: bool = typer.Option(False, "--accept-failed", help="Write the calibration even when a camera fails the quality checks."),
        strict_intrinsics: bool = typer.Option(False, "--strict-intrinsics", help="Hold nothing the board views cannot determine: refuse a camera whose board covered too little of its image or whose focal length is uncertain, instead of holding its principal point at the image centre and only k1."),
        folds: int = typer.Option(5, "--folds", help="Held-out error: split the board frame sets in time into K folds, fit on the rest, judge on each (K more calibrations; 0: skip). A --compare calibration is judged on the same frame sets."),
        choose_intrinsics: bool = typer.Option(False, "--choose-intrinsics", help="Choose each camera's lens model (k1; k1k2; k1k2p1p2k3) and principal point (held at the image centre or free) by held-out error (6 x K more calibrations)."),
        choose_fit: bool = typer.Option(False, "--choose-fit", help="Choose the fit by held-out error: the bundle adjustment's loss (soft-L1 or least squares) and, with --intrinsics, those intrinsics held or the cameras' own from the clip (with --choose-intrinsics: as chosen there) (2 or 4 x K more calibrations)."),
        caliscope_folds: str | None = typer.Option(None, "--caliscope-folds", help="Also fit caliscope's own calibration (pip install -e '.[caliscope]') on each fold's frame sets and judge it on the same held-out ones: 'given' starts it from the --intrinsics (else the --compare calibration's) intrinsics, 'clip' from its own intrinsic calibration of these views."),
        motion: bool = typer.Option(False, "--motion", help="Model the hand-held board's motion: each camera's time offset (webcams are not synchronised) adjusted from the board's motion and views weighted by its speed; the offsets are in the report."),
    ) -> None:
        """Calibrate all cameras from a board recording; writes the calibration and its quality report."""
        from dataclasses import replace

        from gaitcap.acquisition.boards.pairing import PairingConfig
        from gaitcap.acquisition.boards.recording import FrameSelection
        from gaitcap.acquisition.fileio import atomic_write_text
        from gaitcap.acquisition.writers import save_rig
        from gaitcap.reconstruction.calibration import (
            CalibrationConfig,
            DistortionModel,
            IntrinsicsConfig,
            WorldFrameConfig,
            calibrate_from_observations,
        )
        from gaitcap.reconstruction.calibration.compare import (
            compare_rigs,
            compare_similar,
            stereo_difference,
        )
        from gaitcap.reconstruction.calibration.holdout import HoldoutConfig
        from gaitcap.reconstruction.calibration.model_choice import choose_fit as choose_fit_model
        from gaitcap.reconstruction.calibration.model_choice import choose_intrinsics as choose_model
        from gaitcap.reconstruction.calibration.motion import MotionConfig

        with user_errors():
            reference = _load_calibration(compare) if compare is not None else None
            if out.suffix.lower() not in (".toml", ".json"):
                raise ValueError(f"--out {out}: use a .toml or .json file name")
            models = {m.value: m for m in DistortionModel}
            if distortion not in models:
                raise ValueError(f"--distortion: choose one of {sorted(models)}, got {distortion!r}")
            cfg = board_from_options(board_file, board, squares, square_mm, marker_mm, dictionary, inverted, legacy)
            known = _load_calibration(intrinsics) if intrinsics is not None else None
            flags_given = board_file is not None or any(
                v is not None for v in (board, squares, square_mm, marker_mm, dictionary, inverted, legacy))
            config = CalibrationConfig(
                intrinsics=IntrinsicsConfig(distortion=models[distortion], hold_undetermined=not strict_intrinsics),
                world=WorldFrameConfig(floor_frame=floor_frame),
                known_intrinsics={c.name: (c.matrix_px, c.dist) for c in known.cameras} if known else None,
                motion=MotionConfig() if motion else None,
            )
            with progress(desc="finding the board", unit="img") as bar:
                cfg, obs, found, what = _views(recording, cfg, flags_given, FrameSelection(every, max_frames),
                                               PairingConfig(tolerance_ms=sync_tolerance_ms, readout_ms=readout_ms),
                                               lambda done, total: bar.update(1))
            typer.echo(f"board {cfg.describe()}: {what}", err=True)
            refit, refit_label = _caliscope_refit(caliscope_folds, known, reference)
            if refit is not None and not folds:
                raise ValueError("--caliscope-folds: the held-out error is off (--folds 0)")
            if found is not None:
                found.check(config.intrinsics.min_views)
            choice = None
            if choose_intrinsics:
                if known is not None and not choose_fit:
                    raise ValueError("--choose-intrinsics: the intrinsics are given (--intrinsics); nothing to choose "
                                     "(with --choose-fit too, the clip's are chosen, then compared with the given ones)")
                try:
                    with progress(total=6, desc="choosing intrinsics", unit="candidate") as bar:
                        chosen, choice = choose_model(obs, replace(config, known_intrinsics=None),
                                                      holdout=HoldoutConfig(folds=max(folds, 2)),
                                                      progress=lambda done, total: bar.update(1))
                    config = replace(chosen, known_intrinsics=config.known_intrinsics)
                except ValueError as exc:  # no candidate fitted in every fold: the default rule stands, said
                    typer.echo(f"intrinsics not chosen by held-out error ({exc}); the coverage rule is used", err=True)
            fit = None
            if choose_fit:
                with progress(total=4 if known is not None else 2, desc="choosing the fit", unit="candidate") as bar:
                    config, fit = choose_fit_model(obs, config, holdout=HoldoutConfig(folds=max(folds, 2)),
                                                   progress=lambda done, total: bar.update(1))
            result = calibrate_from_observations(obs, config=config,
                                                 views_removed=found.views_removed if found is not None else None)
            held_out = _cross_validate(obs, config, folds, reference, compare, refit, refit_label) if folds else None
            refused = bool(result.report.failed_cameras) and not accept_failed
            target = out.with_name(out.stem + ".refused" + out.suffix) if refused else out
            save_rig(result.rig, target, metadata={"error": result.report.reprojection_rms_px})
            report_file = report_path or out.with_suffix(".report.json")
            report = result.report.to_dict()
            report["held_out"] = held_out.to_dict() if held_out is not None and not isinstance(held_out, str) else held_out
            report["intrinsics_choice"] = choice.to_dict() if choice is not None else None
            report["fit_choice"] = fit.to_dict() if fit is not None else None
            atomic_write_text(report_file, json.dumps(report, indent=2))
            comparison = compare_rigs(reference, result.rig) if reference is not None else None
            similar = compare_similar(reference, result.rig) if reference is not None and len(reference) >= 3 else None
            pair = tuple(reference.names) if reference is not None and len(reference) == 2 else None
            stereo = stereo_difference(reference, result.rig, first=pair[0], second=pair[1]) if pair else None
        if choice is not None:
            typer.echo(_choice(choice))
        if fit is not None:
            typer.echo(_fit_choice(fit))
        typer.echo(_summary(result.report))
        for note in result.report.motion.get("notes", ()):
            typer.echo(f"the board's motion: {note}")
        if held_out is not None:
            typer.echo(held_out if isinstance(held_out, str) else _held_out(held_out))
        if comparison is not None:
            typer.echo(f"compared with {compare}:")
            typer.echo(_comparison(comparison))
        if similar is not None:
            typer.echo(_similar(similar))
            verdict = _which_is_right(similar, held_out)
            if verdict:
                typer.echo(verdict)
        if stereo is not None:
            typer.echo(_stereo(stereo, *pair))
        typer.echo(f"wrote {target} and {report_file}")
        if refused:
            typer.echo(f"calibration refused for use: cameras {list(result.report.failed_cameras)} failed the quality "
                       f"checks (written to {target}; --accept-failed writes it to {out})", err=True)
            raise typer.Exit(code=1)
