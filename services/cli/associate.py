"""``gaitcap associate``: several people in view -> the patient's keypoints for reconstruction."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors


def _point(text: str | None, what: str) -> tuple[float, float, float] | None:
    if text is None:
        return None
    parts = [p for p in text.replace(" ", "").split(",") if p]
    if len(parts) != 3:
        raise ValueError(f"{what}: expected X,Y,Z in mm, got {text!r}")
    return tuple(float(p) for p in parts)


def register(app: typer.Typer) -> None:
    @app.command("associate")
    def associate_cmd(
        keypoints: Path = typer.Argument(..., help="Multi-person keypoints .npz: keypoints (C,T,P,J,3), "
                                         "camera_names, times_s, skeleton."),
        calibration: Path = typer.Option(..., "--calibration", "-c", help="Calibration (.toml or .json)."),
        out: Path = typer.Option(..., "--out", "-o", help="Output .npz with the chosen person's keypoints."),
        track: int | None = typer.Option(None, "--track", help="Choose this track id (manual selection)."),
        start: str | None = typer.Option(None, "--start", help="Choose the person nearest X,Y,Z mm."),
        walkway: str | None = typer.Option(
            None, "--walkway", help="Walkway centre line X0,Y0,Z0,X1,Y1,Z1 mm (default: through the rig)."),
    ) -> None:
        """Associate the people seen by every camera, track them and write the patient's keypoints."""
        from gaitcap.acquisition.readers import load_multi_npz, load_rig
        from gaitcap.acquisition.writers import save_detections_npz
        from gaitcap.reconstruction.association import (
            ManualTrack,
            NearestStartTrack,
            WalkwayTrack,
            associate_and_select,
        )

        with user_errors():
            if sum(v is not None for v in (track, start, walkway)) > 1:
                raise ValueError("give at most one of --track, --start and --walkway")
            multi = load_multi_npz(keypoints)
            rig = load_rig(calibration)
            selector = None  # automatic, as the worker chooses
            if track is not None:
                selector = ManualTrack(track)
            elif start is not None:
                selector = NearestStartTrack(start_mm=_point(start, "--start"))
            elif walkway is not None:
                ends = walkway.split(",")
                if len(ends) != 6:
                    raise ValueError(f"--walkway: expected six numbers X0,Y0,Z0,X1,Y1,Z1, got {walkway!r}")
                selector = WalkwayTrack(start_mm=_point(",".join(ends[:3]), "--walkway"),
                                        end_mm=_point(",".join(ends[3:]), "--walkway"))
            selection = associate_and_select(multi, rig.subset(multi.camera_names), selector)  # the worker's call
            tracks, chosen, det = selection.tracks, selection.track_id, selection.detections
            save_detections_npz(det, out, track_id=chosen,
                                detection_track=tracks.detection_track, track_roots_mm=tracks.root_mm)
        for m in tracks.ids:
            seen = tracks.seen()[m]
            mark = "*" if m == chosen else " "
            t = tracks.times_s[seen]
            typer.echo(f"{mark} track {m}: {seen.sum()} frames, {t[0]:.2f}-{t[-1]:.2f} s, "
                       f"{tracks.views[m][seen].mean():.1f} views on average")
        typer.echo(f"chose track {chosen}; wrote {out}")
