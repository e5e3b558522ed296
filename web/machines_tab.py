"""The Machines tab: pick a task's machine or edit one (TOML, checked by the robot's own model as
it is typed, the refusal's words under the text), its graph (web/machine_graph.py: the current
state filled, a pending decision's target ringed), the autonomy to run it at, and the running
machine's pending decision with what it proposes, the report that led to it and the next
behavior, to confirm, decide by another outcome, force a state, stop, or preview on the twin.

Only widgets and what they read: the desk wires what a click does (web/desk.py)."""

import tomllib
from typing import Any

import numpy as np
import viser
from pydantic import ValidationError

from robot_sim.machines.library import BUILTIN_DIR, builtin_machines
from robot_sim.machines.spec import AUTONOMY_LEVELS, BEHAVIOR_EXITS, TERMINALS, MachineSpec
from web.machine_graph import draw_machine, graph_key
from web.markup import Markup, add_html, show
from web.panel_html import check_html, summary_html
from web.request_tab import RequestTab, set_value
from web.typed_number import PLAIN, FieldError, _Typed

PYTHON_NOTE = (
    "# a Python machine (robot_sim/policies): not written as data, so not editable here;\n"
    "# it runs at autonomy `full` only.\n"
)
SHOWN_PARAMS = ("type", "translation", "rotation", "frame", "duration", "force_threshold", "preset", "action")
EXITS = tuple(dict.fromkeys(e for exits in BEHAVIOR_EXITS.values() for e in exits)) + ("anomaly",)


class MachineText(_Typed):
    """The machine's TOML text: one multi-line input whose reason line says why it cannot be
    sent (not TOML; or the robot's model's refusal, state and field named)."""

    def __init__(self, gui: viser.GuiApi, text: str) -> None:
        self.label = "machine"
        handle = gui.add_text("Machine (TOML)", text, multiline=True, hint="edit: checked as you type")
        super().__init__(gui, "machine", PLAIN, [handle])

    @property
    def value(self) -> dict[str, Any]:
        """The text as TOML (FieldError if it is not)."""
        return self._parsed()

    def _parsed(self) -> dict[str, Any]:
        try:
            return tomllib.loads(self.texts[0])
        except (tomllib.TOMLDecodeError, RecursionError) as err:  # nested thousands deep: not a machine
            raise FieldError(f"not TOML: {err}") from None

    @property
    def text(self) -> str:
        return self.texts[0]

    @text.setter
    def text(self, text: str) -> None:
        self._write([text])


def builtin_text(task: str) -> str:
    """A task's machine as its file says it, or a note that it is Python."""
    path = BUILTIN_DIR / f"{task}.toml"
    return path.read_text(encoding="utf-8") if task in builtin_machines() else PYTHON_NOTE


def decision_html(machine: dict[str, Any] | None, now_sim_s: float | None) -> Markup:
    """The running machine's line: its state, or its pending decision in full."""
    if not machine:
        return Markup(
            '<div id="ptwl-machine" data-state="" data-pending="" '
            'style="font-size:0.85em;padding:0 4px;color:#6b7280">no machine running</div>'
        )
    pending = machine.get("pending")
    head = Markup(
        "<b>{}</b> (autonomy {}), state <b>{}</b>; decisions asked {}, waited {:.1f} s so far"
    ).format(
        machine.get("name", ""),
        machine.get("autonomy", ""),
        machine.get("state", ""),
        machine.get("decisions_waited", 0),
        float(machine.get("waited_s", 0.0)),
    )
    if not pending:
        return Markup(
            '<div id="ptwl-machine" data-state="{}" data-pending="" '
            'style="font-size:0.85em;padding:0 4px">{}</div>'
        ).format(machine.get("state", ""), head)
    report = pending.get("report") or {}
    readings = ", ".join(
        f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
        for k, v in (pending.get("readings") or {}).items()
    )
    waited = f", waiting {now_sim_s - float(pending['asked_at']):.1f} s" if now_sim_s is not None else ""
    nxt = pending.get("next")
    step = (
        ", ".join(f"{k} {v}" for k, v in nxt.items() if k in SHOWN_PARAMS and v is not None)
        if nxt
        else f"the machine ends {pending.get('target')}"
    )
    return Markup(
        '<div id="ptwl-machine" data-state="{}" data-pending="{}" '
        'style="font-size:0.85em;padding:4px;border:2px solid #facc15;border-radius:4px">{}<br>'
        "<b>decision {} waits{}</b> (level {}): {} ended <b>{}</b> ({}); peak {:.1f} N, {:.2f} N m{}<br>"
        "proposes <b>{}</b>: {}</div>"
    ).format(
        machine.get("state", ""),
        pending.get("decision"),
        head,
        pending.get("decision"),
        waited,
        pending.get("level"),
        pending.get("state"),
        pending.get("exit"),
        readings or "no guard read",
        float(report.get("peak_force", 0.0)),
        float(report.get("peak_torque", 0.0)),
        f"; {report['detail']}" if report.get("detail") else "",
        pending.get("target"),
        step,
    )


class MachinesTab(RequestTab):
    behavior = "state_machine"

    def __init__(self, gui: viser.GuiApi, tasks: dict[str, str]) -> None:
        self.tasks = tasks
        names = list(tasks) or ["(none)"]
        self.task = gui.add_dropdown("Task", names, initial_value=names[0])
        self.summary = add_html(gui, summary_html(tasks.get(names[0], "")))
        self.autonomy = gui.add_dropdown(
            "Autonomy",
            AUTONOMY_LEVELS,
            initial_value="full",
            hint="a transition waits for your decision unless its level is below this (off: every one)",
        )
        self.machine = MachineText(gui, builtin_text(names[0]))
        self.check_line = add_html(gui, check_html("state_machine", "", []))
        self.send = gui.add_button(
            "Run machine", color="blue", disabled=True, hint="STOP aborts it like any command"
        )
        self.graph = gui.add_image(np.full((8, 8, 3), 255, dtype=np.uint8), label="graph")
        self.decision = add_html(gui, decision_html(None, None))
        self.confirm = gui.add_button("Confirm", color="green", disabled=True)
        self.outcome = gui.add_dropdown("Other outcome", EXITS, initial_value=EXITS[0])
        self.decide_outcome = gui.add_button("Decide by that outcome", disabled=True)
        self.force_state = gui.add_dropdown("Force state", ["(none)"], initial_value="(none)")
        self.force = gui.add_button("Force it", disabled=True)
        self.stop_machine = gui.add_button("Stop machine", color="red", disabled=True)
        self.preview_next = gui.add_button("Preview next step", disabled=True, hint="a PTWL's, on the twin")
        self.preview_line = add_html(gui, Markup(""))
        self.inputs = [self.task, self.autonomy, self.machine]
        self.typed: dict[str, Any] = {"machine": self.machine}  # the text: not a number, same contract
        self.running: dict[str, Any] | None = None  # telemetry's `machine`
        self._graph_key: tuple[Any, ...] | None = None
        self._checked: tuple[str | None, MachineSpec | None] = (None, None)  # (text, its machine)
        self.task.on_update(lambda _: self._task_picked())
        self.machine.on_update(lambda _: self._draw())
        self._draw()

    # ------------------------------------------------------------- the form
    def _task_picked(self) -> None:
        task = str(self.task.value)
        show(self.summary, summary_html(self.tasks.get(task, "")))
        self.machine.text = builtin_text(task)
        self.machine.disabled = task not in builtin_machines()
        self._draw()

    def show_scene_task(self, scene: str) -> None:
        """Pick the loaded scene's task (each task's machine runs only on its own scene)."""
        if scene in self.tasks and self.task.value != scene:
            set_value(self.task, scene)
            self._task_picked()

    def edited(self) -> bool:
        task = str(self.task.value)
        return task in builtin_machines() and self.machine.text != builtin_text(task)

    def params(self) -> dict[str, Any]:
        """The task's own machine, or the edited text as a whole machine (FieldError: not TOML)."""
        autonomy = str(self.autonomy.value)
        if not self.edited():
            return {"task": str(self.task.value), "autonomy": autonomy}
        return {"machine": self.machine.value, "autonomy": autonomy}

    def in_use(self) -> dict[str, Any]:
        return self.typed if self.edited() else {}

    def spec(self) -> MachineSpec | None:
        """The machine as the form shows it, when it is valid (what the graph draws)."""
        task = str(self.task.value)
        if not self.edited():
            return builtin_machines().get(task)
        text = self.machine.text
        if self._checked[0] != text:  # validated once per text, not on every telemetry change
            try:
                self._checked = (text, MachineSpec.model_validate(self.machine.value))
            except (FieldError, ValidationError):
                self._checked = (text, None)
        return self._checked[1]

    # ----------------------------------------------------- the running one
    def show_running(self, machine: dict[str, Any] | None, now_sim_s: float | None, may_decide: bool) -> None:
        """Telemetry's `machine` (None: none runs): the decision line, the buttons, the graph."""
        show(self.decision, decision_html(machine, now_sim_s))
        pending = bool(machine and machine.get("pending"))
        for button in (self.confirm, self.decide_outcome, self.force, self.stop_machine):
            button.disabled = not (pending and may_decide)
        nxt = (machine or {}).get("pending") or {}
        self.preview_next.disabled = not (pending and (nxt.get("next") or {}).get("type") == "ptwl")
        # After the buttons: whoever reads a pending decision here (a button's callback, on
        # viser's thread) finds the buttons already set for it.
        self.running = machine
        states = list((machine or {}).get("visits", {}) or [])
        spec = self.spec()
        options = [*(spec.states if spec is not None else states), *TERMINALS] or ["(none)"]
        if list(self.force_state.options) != options:
            self.force_state.options = options
        self._draw()

    def decision_body(self, choice: str) -> tuple[int, dict[str, Any]] | None:
        """(command id, the decision's body) for the pending decision, or None if none waits."""
        machine = self.running
        pending = (machine or {}).get("pending")
        if not machine or not pending:
            return None
        body: dict[str, Any] = {"decision": int(pending["decision"]), "choice": choice}
        if choice == "outcome":
            body["outcome"] = str(self.outcome.value)
        if choice == "force":
            body["state"] = str(self.force_state.value)
        return int(machine["command"]), body

    def next_step(self) -> dict[str, Any] | None:
        """The pending decision's proposed next behavior's parameters (a PTWL's is previewed)."""
        pending = (self.running or {}).get("pending") or {}
        nxt = pending.get("next")
        return {k: v for k, v in nxt.items() if v is not None and k != "type"} if nxt else None

    def _draw(self) -> None:
        spec = self.spec()
        shown = self.running
        running = shown if spec is not None and shown and shown.get("name") == spec.name else None
        key = graph_key(spec, running)
        if key == self._graph_key:
            return
        self._graph_key = key
        if spec is None:
            self.graph.visible = False
            return
        pending = (running or {}).get("pending") or {}
        self.graph.image = draw_machine(spec, (running or {}).get("state"), pending.get("target"))
        self.graph.visible = True
