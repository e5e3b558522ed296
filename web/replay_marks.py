"""Where a recording's commands ran, on the replay's timeline: numbered marks on the time slider
(a command's start, labelled with its number, and its end) and a strip under it from 0 s to the
recording's end, one bar a command from start to end in its exit's colour, the playhead across
it, and the numbers, commands and exits in words.

The strip's data-* attributes mirror what it shows (positions as fractions of the recording's
duration), for tests."""

from web.history import PHASE_COLORS, exit_color_hex
from web.markup import Markup
from web.replay_record import CommandSpan

PLAYHEAD_COLOR = "#7048e8"
LISTED = 12  # commands named under the strip; more are counted ("+3 more")


def slider_marks(commands: list[CommandSpan], end_s: float) -> tuple[float | tuple[float, str], ...]:
    """The slider's marks: its two ends in seconds, each command's start (its number) and end."""
    marks: list[float | tuple[float, str]] = [(0.0, "0"), (end_s, f"{end_s:.1f} s")]
    for command in commands:
        marks.append((_within(command.start_s, end_s), str(command.number)))
        if command.end_s is not None:
            marks.append(_within(command.end_s, end_s))
    return tuple(marks)


def marks_html(commands: list[CommandSpan] | None, duration_s: float, position_s: float, note: str) -> Markup:
    """The strip; `commands` None while the recording is read (or when it cannot be: `note`)."""
    if commands is None:
        return Markup(
            '<div id="ptwl-replay-marks" data-count="" style="font-size:0.8em;color:#868e96">'
            "commands on the timeline: {}</div>"
        ).format(note)
    duration = max(duration_s, 1e-9)
    starts = [_within(c.start_s, duration) / duration for c in commands]
    ends = [_within(c.end_s if c.end_s is not None else duration, duration) / duration for c in commands]
    bars = Markup("").join(
        Markup(
            '<span title="{number} {label}: {start:.2f} to {end} s, {exit}" style="position:absolute;'
            "left:{left:.3f}%;width:{width:.3f}%;min-width:2px;top:2px;bottom:2px;"
            'background:{color};opacity:0.85"></span>'
        ).format(
            number=c.number,
            label=c.label,
            start=c.start_s,
            end=f"{c.end_s:.2f}" if c.end_s is not None else "the end",
            exit=c.exit or "running",
            left=100.0 * start,
            width=100.0 * (end - start),
            color=_color(c),
        )
        for c, start, end in zip(commands, starts, ends, strict=True)
    )
    named = Markup(" · ").join(
        Markup("<b>{}</b> {} {}").format(c.number, c.label, c.exit or "running") for c in commands[:LISTED]
    )
    more = Markup(" · +{} more").format(len(commands) - LISTED) if len(commands) > LISTED else Markup("")
    return Markup(
        '<div id="ptwl-replay-marks" data-count="{count}" data-starts="{starts}" data-ends="{ends}" '
        'data-exits="{exits}" data-position="{position:.4f}" style="font-size:0.8em">'
        '<div style="position:relative;height:14px;background:#f1f3f5;border-radius:2px;margin:2px 0">'
        "{bars}"
        '<span style="position:absolute;left:{position_pct:.3f}%;top:0;bottom:0;width:2px;'
        'background:{playhead}"></span></div>'
        '<div style="display:flex;justify-content:space-between;color:#868e96">'
        "<span>0 s</span><span>{duration:.1f} s</span></div>"
        "{listed}{more}</div>"
    ).format(
        count=len(commands),
        starts=",".join(f"{s:.4f}" for s in starts),
        ends=",".join(f"{e:.4f}" for e in ends),
        exits=",".join(c.exit or "running" for c in commands),
        position=_within(position_s, duration) / duration,
        bars=bars,
        position_pct=100.0 * _within(position_s, duration) / duration,
        playhead=PLAYHEAD_COLOR,
        duration=duration_s,
        listed=named if commands else Markup("no commands in this recording"),
        more=more,
    )


def _within(t_s: float, end_s: float) -> float:
    return min(max(t_s, 0.0), end_s)


def _color(command: CommandSpan) -> str:
    if command.exit is None:
        return PHASE_COLORS["running"]
    return exit_color_hex(command.exit)
