"""The console form's HTML lines, built from literal templates (web/markup.py): who has control,
a request's check line, the contemplated target in words, the gains, the frames and the preview."""

import re
from typing import Any

import numpy as np
import viser.transforms as tf

from web.markup import Markup


def control_html(mine: bool, holder: str | None) -> Markup:
    if mine:
        text, color = Markup("You have control: your commands go to the robot."), "#2f9e44"
    elif holder:
        text = Markup("Watching: <b>{}</b> has control. Your fields are your own.").format(holder)
        color = "#868e96"
    else:
        text, color = Markup("Watching: nobody has control. Take it to send."), "#868e96"
    return Markup(
        '<div id="ptwl-control" data-mine="{}" data-holder="{}" '
        'style="padding:4px 8px;border-left:6px solid {}">{}</div>'
    ).format(int(mine), holder or "", color, text)


def gains_html(stiffness: list[float], damping: list[float], element_id: str, title: str = "") -> Markup:
    """K, B and the time constant tau = B/K per axis group (translation, rotation)."""
    k, b = np.asarray(stiffness, dtype=float), np.asarray(damping, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(k > 0, b / k, np.inf)

    def row(name: str, sl: slice, k_unit: str, b_unit: str) -> str:
        ks = ", ".join(f"{v:g}" for v in k[sl])
        bs = ", ".join(f"{v:g}" for v in b[sl])
        taus = ", ".join("∞" if not np.isfinite(v) else f"{v:.2f}" for v in tau[sl])
        return f"{name}: K ({ks}) {k_unit} · B ({bs}) {b_unit} · τ ({taus}) s"

    return Markup(
        '<div id="{}" data-k="{}" data-b="{}" title="{}" style="font-size:0.8em;color:#495057;padding:0 4px">'
        "{}<br>{}</div>"
    ).format(
        element_id,
        ",".join(f"{v:g}" for v in k),
        ",".join(f"{v:g}" for v in b),
        title,
        row("translation", slice(0, 3), "N/m", "N s/m"),
        row("rotation", slice(3, 6), "N m/rad", "N m s/rad"),
    )


def summary_html(summary: str) -> Markup:
    return Markup('<div style="font-size:0.85em;padding:0 4px">{}</div>').format(summary)


def field_named(item: dict[str, Any], fields: dict[str, Any]) -> str:
    """The request field an API error item is about: `translation` for `translation[1]`; for a
    rule across fields (`body`), the field its message starts with ("watchdog (3 s) must ...")."""
    name = re.split(r"[\[.]", str(item["field"]), maxsplit=1)[0]
    if name == "body":
        name = str(item["message"]).split(" ", 1)[0]
    return name if name in fields else ""


def check_html(behavior: str, errors: str, warnings: list[str], unreadable: str = "") -> Markup:
    if unreadable:  # not judged by the robot's rules at all: there is no request yet
        body, color = f"not sent until fixed: {unreadable}", "#e03131"
    elif errors:
        body, color = f"will be refused: {errors}", "#e03131"
    elif warnings:
        body, color = "accepted, but: " + " ".join(warnings), "#e8590c"
    else:
        body, color = "within the robot's limits", "#868e96"
    return Markup(
        '<div id="ptwl-check-{}" data-valid="{}" data-readable="{}" data-warnings="{}" '
        'style="font-size:0.8em;color:{};padding:0 4px">{}</div>'
    ).format(behavior, int(not (errors or unreadable)), int(not unreadable), len(warnings), color, body)


def contemplated_html(distance_mm: float | None, why_not: str = "") -> Markup:
    """The contemplated target in words, as the 3D view draws it (the DOM can read this line; the
    WebGL view it mirrors it cannot)."""
    if distance_mm is None:
        return Markup(
            '<div id="ptwl-contemplated" data-shown="0" data-distance="" '
            'style="font-size:0.8em;color:#868e96;padding:0 4px">no target drawn: {}</div>'
        ).format(why_not)
    return Markup(
        '<div id="ptwl-contemplated" data-shown="1" data-distance="{:.1f}" '
        'style="font-size:0.8em;color:#868e96;padding:0 4px">target {:.1f} mm from the port</div>'
    ).format(distance_mm, distance_mm)


def frames_html(frames: list[dict[str, Any]]) -> Markup:
    """The task frames the robot has, each with its pose in base axes (origin, and rotation as the
    typed rotation reads it: a rotation vector) and where it came from."""
    row = Markup(
        "<li><b>{}</b> origin ({:.1f}, {:.1f}, {:.1f}) mm, rotation ({:.1f}, {:.1f}, {:.1f}) deg "
        "<span style='color:#868e96'>({}: {})</span></li>"
    )
    rows = Markup("").join(
        row.format(f["name"], *_origin_mm(f), *_rotation_deg(f), f["source"], f["defined_by"]) for f in frames
    )
    body = (
        Markup("<ul style='margin:0;padding-left:16px'>{}</ul>").format(rows)
        if frames
        else "only tool and base"
    )
    return Markup('<div id="ptwl-frames" data-names="{}" style="font-size:0.85em">{}</div>').format(
        ",".join(f["name"] for f in frames), body
    )


def _origin_mm(frame: dict[str, Any]) -> list[float]:
    return [1000.0 * v for v in frame["pose"]["position"]]


def _rotation_deg(frame: dict[str, Any]) -> list[float]:
    return np.degrees(tf.SO3(np.asarray(frame["pose"]["quaternion"], dtype=float)).log()).tolist()


def preview_html(result: Any, note: str = "", state: str = "") -> Markup:
    """What the preview says (a PreviewResult, with `note` on where it started; None: `note`, why
    there is none): exit, when, peak; `state` "computing" (since `note`) or "stale" (the fields
    changed since it ran: it is not what Send would do now)."""
    if state == "computing":
        return Markup(
            '<div id="ptwl-preview" data-exit="" data-state="computing" '
            'style="color:#1971c2;font-size:0.85em">preview: computing (since {})…</div>'
        ).format(note)
    if result is None:
        return Markup(
            '<div id="ptwl-preview" data-exit="" data-state="" '
            'style="color:#868e96;font-size:0.85em">{}</div>'
        ).format(note or "no preview yet")
    stale = (
        Markup(' <b style="color:#e8590c">STALE: the fields changed since; preview again</b>')
        if state == "stale"
        else ""
    )
    return Markup(
        '<div id="ptwl-preview" data-exit="{exit}" data-state="{state}" data-duration="{duration:.3f}" '
        'data-peak-force="{force:.3f}" data-compute-s="{compute:.3f}" style="font-size:0.85em;{faded}">'
        "preview: <b>{exit}</b> after {duration:.2f} s, peak {force:.1f} N / {torque:.2f} N m "
        '<span style="color:#868e96">(computed in {compute:.2f} s{started})</span>{stale}</div>'
    ).format(
        exit=result.exit,
        state=state,
        duration=result.duration_s,
        force=result.peak_force_n,
        torque=result.peak_torque_nm,
        compute=result.compute_s,
        started=f"; {note}" if note else "",
        faded="opacity:0.6" if state == "stale" else "",
        stale=stale,
    )
