"""Run report: ``scripts/report <run-dir-or-bag> [--out DIR] [--video [mp4|gif]]``.

The report says what happened first: one outcome line per demo or experiment (from the run
directory's ``outcomes.json``, written by scripts/demo, or an experiment's ``results.json``), else
per bag (the outcome readers subsystems register, :mod:`.core.run_outcome`), on the console, at
the top of ``report.md`` and as ``outcomes`` in ``report.json``. Below come each bag's inventory
(topics, counts, rates), its plots and, with ``--video``, its top-view camera as MP4 (or GIF) with
markers drawn (:mod:`.core.video`). Works without the ROS environment (messages are decoded from
the bags' own definitions).

Subsystems add plots, outcome readers and scene readers for their message types as plug-ins: a
package lists the modules that call ``register_plot``, ``register_outcome`` or
``register_scene_reader`` in its ament index resource ``collab_report_plots`` (one module name per
line); they are imported before the bags are read, when the workspace environment is available.

Default report directory: ``<run-dir>/report/`` for a run directory, or
``<bag>/../report/<bagname>/`` for a single bag.  With several bags, each
bag's plots go to a sub-directory named after the bag (relative to the run
directory), so equal bag names in different sub-directories do not collide.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from datetime import datetime, timezone
from pathlib import Path

from .core.bag_analysis import BagSummary, find_bags, format_summary, summarize_bag
from .core.report_plots import write_plots
from .core.run_outcome import Outcome, bag_outcomes, markdown_escape, outcome_markdown, run_outcomes
from .core.scene_layout import scene_of_bag

EXIT_OK = 0
EXIT_NO_BAG = 2
VIDEO_FORMATS = ('mp4', 'gif')


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='report',
        description='Summarize the rosbag2 bags of a run (or one bag): tables, plots, report.json, report.md.',
    )
    parser.add_argument('path', type=Path, help='a run directory (bags at any depth) or one bag directory')
    parser.add_argument('--out', type=Path, default=None,
                        help='report directory (default: <run-dir>/report or <bag>/../report/<bagname>)')
    parser.add_argument('--video', nargs='?', const='mp4', choices=VIDEO_FORMATS, default=None,
                        help="also export each bag's top-view camera with markers drawn, as MP4 (default) or GIF")
    parser.add_argument('--video-speed', type=float, default=4.0, metavar='X',
                        help='video playback speed relative to simulated time (default 4)')
    return parser


def _bag_label(bag: Path, root: Path, single: bool) -> str:
    if single:
        return bag.name
    try:
        rel = bag.relative_to(root)
    except ValueError:
        return bag.name
    return rel.as_posix() if rel.parts else bag.name


def _rel(path: Path, base: Path) -> str:
    try:
        return path.resolve().relative_to(base.resolve()).as_posix()
    except ValueError:
        return str(path.resolve())


def _bag_entry(summary: BagSummary, label: str, plots: list[Path], out_dir: Path,
               outcomes: list[Outcome] = (), videos: list[dict] = ()) -> dict:
    return {
        'name': label,
        'outcomes': [o.to_dict() for o in outcomes],
        'path': str(summary.path.resolve()),
        'storage': summary.storage,
        'duration_s': summary.duration_s,
        'start_ns': summary.start_ns,
        'end_ns': summary.end_ns,
        'message_count': summary.message_count,
        'messages_lost': summary.lost,    # the recorder's count per topic (None: not counted)
        'repaired': summary.repaired,     # what bag_reindex did after the recorder died
        'topics': [
            {
                'topic': t.topic,
                'type': t.type_name,
                'count': t.count,
                'rate_hz': t.rate_hz,
                'first_ns': t.first_ns,
                'last_ns': t.last_ns,
            }
            for t in summary.topics
        ],
        'plots': [_rel(p, out_dir) for p in plots],
        'videos': list(videos),
    }


_md_escape = markdown_escape
_outcome_lines = outcome_markdown   # the same lines open every experiment's own report


def _markdown(report: dict) -> str:
    lines = ['# Run report', '', '## Outcome', '']
    lines += _outcome_lines(report['outcomes']) or ['- no outcome recorded (no results file, no bag a reader knows)']
    lines += ['', f'Source: `{report["source"]}`  ', f'Generated: {report["generated"]}', '', '## Recordings', '']
    for bag in report['bags']:
        lines += [f'### {_md_escape(bag["name"])}', '']
        if bag.get('outcomes'):
            lines += _outcome_lines(bag['outcomes']) + ['']
        lines += [
            f'- path: `{bag["path"]}`',
            f'- storage: {bag["storage"]}',
            f'- duration: {bag["duration_s"]:.3f} s',
            f'- messages: {bag["message_count"]}',
        ]
        for video in bag.get('videos', []):
            lines.append(f'- video: [{video["path"]}]({video["path"]}) ({video["frames"]} frames of '
                         f'{video["width"]}x{video["height"]} at {video["fps"]:g} fps, from `{video["camera_topic"]}`)')
        lines += [
            '',
            '| topic | type | count | rate [Hz] |',
            '| --- | --- | ---: | ---: |',
        ]
        for t in bag['topics']:
            lines.append(
                f'| `{_md_escape(t["topic"])}` | `{_md_escape(t["type"])}` | {t["count"]} | {t["rate_hz"]:.2f} |'
            )
        if not bag['topics']:
            lines.append('| (no topics) | | | |')
        lines.append('')
        for plot in bag['plots']:
            lines += [f'![{Path(plot).stem}]({plot})', '']
        if bag.get('errors'):
            lines += ['Errors:', ''] + [f'- {e}' for e in bag['errors']] + ['']
    return '\n'.join(lines)


PLOT_PLUGIN_RESOURCE = 'collab_report_plots'


def load_plot_plugins() -> list[str]:
    """Import every plot module registered in the ament index; return their names.

    A plug-in that fails to import is reported and skipped: its bags still get the
    built-in plots.
    """
    try:
        from ament_index_python.packages import get_resource, get_resources
    except ImportError:  # outside the ROS environment: built-in plots only
        return []
    loaded = []
    for package in sorted(get_resources(PLOT_PLUGIN_RESOURCE)):
        content, _ = get_resource(PLOT_PLUGIN_RESOURCE, package)
        for module in (line.strip() for line in content.splitlines()):
            if not module or module.startswith('#'):
                continue
            try:
                importlib.import_module(module)
                loaded.append(module)
            except Exception as error:  # noqa: BLE001 - any plug-in failure is reported, not fatal
                print(f'report: plot plug-in {module} (package {package}) not loaded: {error}',
                      file=sys.stderr)
    return loaded


def _export_video(bag: Path, summary: BagSummary, plot_dir: Path, out_dir: Path, fmt: str,
                  speed: float) -> list[dict]:
    from .core.video import export_video   # OpenCV only when a video is asked for
    try:
        info = export_video(bag, summary, plot_dir / f'top_camera.{fmt}', fmt, speed=speed, layout=scene_of_bag(bag))
    except Exception as error:  # noqa: BLE001 - a broken frame must not sink the report
        print(f'report: {bag.name}: no video ({type(error).__name__}: {error})', file=sys.stderr)
        return []
    if info is None:
        print(f'report: {bag.name}: no camera frames recorded, no video', file=sys.stderr)
        return []
    return [{'path': _rel(info.path, out_dir), 'format': fmt, 'frames': info.frames, 'width': info.width,
             'height': info.height, 'fps': info.fps, 'camera_topic': info.camera_topic}]


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.video_speed <= 0:
        print(f'report: --video-speed must be > 0 (got {args.video_speed})', file=sys.stderr)
        return EXIT_NO_BAG
    load_plot_plugins()
    source: Path = args.path
    try:
        bags = find_bags(source)
    except FileNotFoundError as exc:
        print(f'report: {exc}', file=sys.stderr)
        return EXIT_NO_BAG

    if source.is_file():  # e.g. <bag>/metadata.yaml or <bag>/<bag>_0.mcap
        source = bags[0]
    single_bag_given = len(bags) == 1 and bags[0].resolve() == source.resolve()
    if args.out is not None:
        out_dir = args.out
    elif single_bag_given:
        out_dir = source.resolve().parent / 'report' / bags[0].name
    else:
        out_dir = source / 'report'
    out_dir.mkdir(parents=True, exist_ok=True)

    stated = [] if single_bag_given else run_outcomes(source)
    entries, inventories = [], []
    status = EXIT_OK
    single = len(bags) == 1
    for bag in bags:
        label = _bag_label(bag, source, single)
        try:
            summary = summarize_bag(bag)
        except Exception as exc:  # noqa: BLE001 - report the other bags anyway
            print(f'report: cannot read bag {bag}: {type(exc).__name__}: {exc}', file=sys.stderr)
            entries.append({'name': label, 'path': str(bag.resolve()), 'outcomes': [], 'storage': 'unknown',
                            'duration_s': 0.0, 'start_ns': 0, 'end_ns': 0, 'message_count': 0,
                            'topics': [], 'plots': [], 'videos': [],
                            'errors': [f'{type(exc).__name__}: {exc}']})
            status = 1
            continue
        plot_dir = out_dir if single else out_dir / label
        outcomes = bag_outcomes(bag, summary)
        plots = write_plots(bag, summary, plot_dir)
        videos = _export_video(bag, summary, plot_dir, out_dir, args.video, args.video_speed) if args.video else []
        entries.append(_bag_entry(summary, label, plots, out_dir, outcomes, videos))
        inventories.append(format_summary(summary))

    # What happened comes first: the run's own outcomes, else every bag's.
    outcomes = [o.to_dict() for o in stated] or [o for entry in entries for o in entry['outcomes']]
    verdicts = [o['passed'] for o in outcomes if o.get('passed') is not None]
    report: dict = {
        'passed': all(verdicts) if verdicts else None,
        'outcomes': outcomes,
        'source': str(source.resolve()),
        'generated': datetime.now(timezone.utc).isoformat(timespec='seconds'),
        'bags': entries,
    }
    for outcome in outcomes:
        print(f'outcome: {outcome["line"]}')
    if not outcomes:
        print('outcome: none recorded (no results file, no bag a reader knows)')
    print()
    for inventory in inventories:
        print(inventory)
        print()
    for entry in entries:
        for video in entry['videos']:
            print(f'report: video {out_dir / video["path"]} ({video["frames"]} frames, {video["fps"]:g} fps)')

    (out_dir / 'report.json').write_text(json.dumps(report, indent=2) + '\n', encoding='utf-8')
    (out_dir / 'report.md').write_text(_markdown(report) + '\n', encoding='utf-8')
    print(f'report: {out_dir.resolve()}')
    return status


if __name__ == '__main__':
    sys.exit(main())
