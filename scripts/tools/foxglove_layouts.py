#!/usr/bin/env python3
"""Write (or check) the Foxglove layouts of config/foxglove/, one per subsystem.

Each layout is built with foxglove-sdk's typed layout models (``foxglove.layouts``, the app's own
layout format): a 3D panel with the subsystem's markers (``/markers/<source>``, the visualiser's
topics) and the TF tree in the world frame, an image panel with the top camera, plots of a few key
fields and a raw view of the subsystem's main message. Import one in the Foxglove app: Layouts ->
Import from file. Topic names are those of a session in the default namespace ``/``.

    scripts/tools/foxglove_layouts.py           # write config/foxglove/*.json
    scripts/tools/foxglove_layouts.py --check   # exit 1 if a file differs from what is built here
"""
import argparse
import json
import sys
from pathlib import Path

import foxglove.layouts as fl

OUT = Path(__file__).resolve().parents[2] / 'config' / 'foxglove'
CAMERA = '/top_camera/image_raw/compressed'   # JPEG: what a remote viewer should pull (README: compressed camera)
RTF = fl.PlotSeries(value='/pybullet_bridge/status.measured_real_time_factor', label='real-time factor')
MOBILE = '/ground_truth/bodies.bodies[:]{kind=="mobile_robot"}'


def three_dee(markers: str, extra_topics: dict | None = None) -> fl.ThreeDeePanel:
    topics = {markers: fl.BaseRendererRosMarkerTopicSettings(visible=True), **(extra_topics or {})}
    return fl.ThreeDeePanel(title=f'3D: {markers} + TF', config=fl.ThreeDeeConfig(
        follow_tf='world', topics=topics,
        layers={'grid': fl.BaseRendererGridLayerSettings(frame_id='world', size=10.0, divisions=20.0)}))


def layout(markers: str, plots: list, raw_topic: str, extra_topics: dict | None = None) -> fl.Layout:
    right = fl.SplitContainer(direction='column', items=[
        fl.SplitItem(proportion=1, content=fl.ImagePanel(
            title='top camera', config=fl.ImageConfig(image_mode=fl.ImageModeConfig(image_topic=CAMERA)))),
        fl.SplitItem(proportion=1, content=fl.PlotPanel(title='key fields', config=fl.PlotConfig(paths=plots))),
        fl.SplitItem(proportion=1, content=fl.RawMessagesPanel(
            title=raw_topic, config=fl.RawMessagesConfig(topic_path=raw_topic))),
    ])
    return fl.Layout(content=fl.SplitContainer(direction='row', items=[
        fl.SplitItem(proportion=2, content=three_dee(markers, extra_topics)),
        fl.SplitItem(proportion=1, content=right),
    ]))


def layouts() -> dict[str, fl.Layout]:
    occupancy = {'/roles/map': fl.BaseRendererRosOccupancyGridTopicSettings(visible=True)}
    return {
        'sgcm': layout('/markers/sgcm', [
            fl.PlotSeries(value='/sgcm/guidance.predicted_leader_value', label='v^A (leader, predicted)'),
            fl.PlotSeries(value='/sgcm/guidance.predicted_follower_value', label='v^B (follower, predicted)'),
            fl.PlotSeries(value='/sgcm/guidance.planning_seconds', label='planning s'), RTF], '/sgcm/guidance'),
        'roles': layout('/markers/roles', [
            fl.PlotSeries(value=f'{MOBILE}.twist.linear.x', label='robots: vx (m/s)'),
            fl.PlotSeries(value=f'{MOBILE}.twist.linear.y', label='robots: vy (m/s)'),
            fl.PlotSeries(value='/roles/channel.version', label='process role versions'), RTF],
            '/roles/assignment', occupancy),
        'coalitions': layout('/markers/coalitions', [
            fl.PlotSeries(value=f'{MOBILE}.pose.position.x', label='robots: x (m)'),
            fl.PlotSeries(value=f'{MOBILE}.pose.position.y', label='robots: y (m)'), RTF],
            '/coalition/channel'),
    }


def rendered(item: fl.Layout) -> str:
    return json.dumps(json.loads(item.to_json()), indent=2) + '\n'


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--check', action='store_true', help='compare instead of writing')
    args = parser.parse_args(argv)
    stale = []
    for name, item in layouts().items():
        path = OUT / f'{name}.json'
        text = rendered(item)
        if args.check:
            if not path.is_file() or path.read_text() != text:
                stale.append(str(path))
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f'wrote {path}')
    if stale:
        print('out of date (run scripts/tools/foxglove_layouts.py): ' + ', '.join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
