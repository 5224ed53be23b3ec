"""``gaitcap validate TRIAL REFERENCE --out DIR`` and ``gaitcap validate-study PAIRS --out DIR``: agreement
of gaitcap's results with a lab's reference recordings (docs/validation.md)."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from gaitcap.services.cli._common import progress, user_errors


def _n(x, spec: str) -> str:
    """A number as ``spec`` formats it, "-" for none (NaN is None in the result)."""
    return "-" if x is None else format(x, spec)


def _echo(result: dict) -> None:
    a = result["alignment"]
    typer.echo(f"{result['trial']} ({result['stage']}) vs {result['reference']} ({result['reference_kind']})")
    typer.echo(f"alignment: lag {a['lag_s']:+.3f} s ({a['lag_frames']:+.2f} frames), rotation {a['rotation_deg']:.1f} "
               f"deg, residual {a['residual_mm']:.1f} mm")
    for e in result["events"]:
        typer.echo(f"  {e['side']:5s} {e['kind']:11s} n={e['n']} signed median {_n(e['signed_median_frames'], '+.2f')} "
                   f"frames ({_n(e['signed_median_ms'], '+.0f')} ms), |e| median {_n(e['abs_median_frames'], '.2f')} "
                   f"frames, missed {e['missed']}, extra {e['extra']}")
    for name, sides in result["parameters"].items():
        s = sides["all"]
        typer.echo(f"  {name:20s} n={s['n']} bias {_n(s['bias'], '+.2f')} LoA {_n(s['loa_low'], '+.2f')}.."
                   f"{_n(s['loa_high'], '+.2f')} ICC(A,1) {_n(s['icc'], '.2f')} MAE {_n(s['mae'], '.2f')}")
    for name, v in result["trial_parameters"].items():
        typer.echo(f"  {name:20s} trial {_n(v['trial'], '.2f')} reference {_n(v['reference'], '.2f')}")
    for x in result["angles"]:
        typer.echo(f"  {x['side']:5s} {x['variable']:18s} RMSE {_n(x['rmse_deg'], '.1f')} offset "
                   f"{_n(x['offset_deg'], '+.1f')} RMSE after offset {_n(x['rmse_after_offset_deg'], '.1f')} deg, "
                   f"r {_n(x['r'], '.3f')}, min {_n(x['trial_min_deg'], '.1f')} (reference "
                   f"{_n(x['reference_min_deg'], '.1f')})")
    for line in result["not_compared"]:
        typer.echo(f"not compared: {line}", err=True)


def register(app: typer.Typer) -> None:
    @app.command("validate")
    def validate_cmd(
        trial: Path = typer.Argument(..., help="A gaitcap process output folder or a clinic trial folder."),
        reference: Path = typer.Argument(..., help="The reference recording of the same walk: C3D (markers, "
                                         "events, model angles), TRC, or a walkway CSV."),
        out: Path = typer.Option(..., "--out", help="Output folder: validation.json, .csv, .pdf, "
                                 "bland_altman.png, angles.png."),
        stage: str | None = typer.Option(None, "--stage", help="preliminary | refined (default: the last there)."),
        as_json: bool = typer.Option(False, "--json", help="Print the result as one JSON object."),
    ) -> None:
        """Agreement of one trial with a reference recording: alignment, events, parameters, angles."""
        from gaitcap.services.validation.files import write_validation

        with user_errors():
            result = write_validation(trial, reference, out, stage=stage)
        if as_json:
            typer.echo(json.dumps(result))
        else:
            _echo(result)
            typer.echo(f"files: {out}/")

    @app.command("validate-study")
    def validate_study_cmd(
        pairs: Path = typer.Argument(..., help="A CSV of pairs (columns trial, reference) or a folder of "
                                     "<name>/ trial folders each beside a reference <name>.c3d|.trc|.csv."),
        out: Path = typer.Option(..., "--out", help="Output folder: study.json, study.csv, one folder per pair."),
        executor: str = typer.Option("local", "--executor", help="inline | local | ray."),
        workers: int | None = typer.Option(None, "--workers", help="Local pool processes."),
        as_json: bool = typer.Option(False, "--json", help="Print the study table as one JSON object."),
    ) -> None:
        """A validation study over many pairs: the table a validation paper reports, and the pairs that
        dominate the disagreement."""
        from gaitcap.services.validation.study import find_pairs, run_study

        with user_errors():
            items = find_pairs(pairs)
            with progress(desc="pairs", unit="pair", total=len(items)) as bar:
                study = run_study(items, out, executor=executor, workers=workers, on_pair=lambda: bar.update(1))
        if as_json:
            typer.echo(json.dumps(study))
            return
        typer.echo(f"{study['pairs_ok']} of {len(items)} pairs compared ({study['icc_form']})")
        for row in study["table"]:
            typer.echo(f"  {row['parameter']:20s} n={row['n']} bias {_n(row['bias'], '+.2f')} LoA "
                       f"{_n(row['loa_low'], '+.2f')}..{_n(row['loa_high'], '+.2f')} ICC(A,1) {_n(row['icc'], '.2f')}"
                       + (f"  dominated by {', '.join(row['dominant_pairs'])}" if row["dominant_pairs"] else ""))
        for p in study["failed"]:
            typer.echo(f"not compared: {p['name']}: {p['error']}", err=True)
        typer.echo(f"files: {out}/")
