"""The history in the paper's terms (issue 27.5): counts per scene, state machine steps counted as
the behaviors they ran (Table 3 counts behaviors, not commands), short ids. On main the counts ran
on across scenes and left out every behavior run inside a state machine."""

from web.board import STEPS_SHOWN, _history_html, _steps_html
from web.history import CommandHistory


def ended(history: CommandHistory, command_id: int, behavior: str, exit: str, **more: object) -> None:
    history.event({"id": command_id, "behavior": behavior, "status": "done", "exit": exit, **more})


def step(behavior: str, exit: str, force: float) -> dict[str, object]:
    return {"behavior": behavior, "exit": exit, "why": "", "peak_force": force, "peak_torque": 0.1}


def test_counts_are_per_scene_and_count_the_steps_of_state_machines() -> None:
    history = CommandHistory()
    history.set_scene("free_space")
    ended(history, 1795000000000001, "ptwl", "goal_reached", peak_force=3.0)
    ended(history, 1795000000000006, "dither", "completed", peak_force=2.0)
    history.set_scene("sleeve_on_peg")
    ended(history, 1795000000000002, "ptwl", "timeout", peak_force=18.7)
    ended(history, 1795000000000003, "rwe", "completed")
    steps = [
        step("ptwl", "wrench_breach", 21.0),
        step("rwe", "completed", 5.0),
        step("ptwl", "timeout", 19.0),
    ]
    ended(history, 1795000000000004, "state_machine", "completed", steps=steps)
    ended(history, 1795000000000005, "ptwl", "refused")  # never ran: not counted
    sleeve = history.counts("sleeve_on_peg")
    assert sleeve["ptwl"] == {"timeout": 2, "wrench_breach": 1}
    assert (sleeve["ptwl_total"], sleeve["rwe"], sleeve["behaviors"]) == (3, 2, 5)
    assert sleeve["peak_force"] == 21.0
    free = history.counts("free_space")
    assert (free["ptwl_total"], free["dither"], free["behaviors"], free["peak_force"]) == (1, 1, 2, 3.0)
    assert history.counts()["behaviors"] == 7  # every scene


def test_the_breakdown_reads_as_the_papers_table_with_short_ids() -> None:
    history = CommandHistory()
    history.set_scene("sleeve_on_peg")
    ended(history, 1795000000000002, "ptwl", "timeout", peak_force=18.7)
    ended(history, 1795000000000003, "rwe", "completed")
    ended(history, 1795000000000004, "ptwl", "timeout", peak_force=12.0)
    ended(history, 1795000000000005, "ptwl", "anomaly", peak_force=12.0)
    html = str(
        _history_html(history.counts("sleeve_on_peg"), list(reversed(history.recent(8))), "sleeve_on_peg")
    )
    assert 'data-behaviors="4" data-ptwl="3" data-rwe="1" data-scene="sleeve_on_peg"' in html
    assert "<td>RWE</td><td style='text-align:right'>1 (25%)</td>" in html
    assert "<td>PTWL</td><td style='text-align:right'>3 (75%)</td>" in html
    assert "<td>PTWL timeout</td><td style='text-align:right'>2</td>" in html
    assert "<td>PTWL other</td><td style='text-align:right'>anomaly 1</td>" in html
    assert "<td>Max force [N]</td><td style='text-align:right'>18.7</td>" in html
    assert '<td title="#1795000000000005">#…0005</td>' in html  # the full id on hover
    assert ">1795000000000005<" not in html


def test_a_long_machine_lists_its_latest_steps_numbered_as_it_counts_them() -> None:
    """A 100-cycle tool exchange runs ~1,500 steps: the Tasks tab lists the latest 30."""
    steps = [{"behavior": "ptwl", "exit": "goal_reached", "why": f"step <b>{i}</b>"} for i in range(45)]
    html = str(_steps_html(steps))
    assert html.count("<li ") == STEPS_SHOWN == 30
    assert 'data-count="45" start="16"' in html and "15 earlier steps not listed" in html
    assert (
        "step &lt;b&gt;44&lt;/b&gt;" in html and "step &lt;b&gt;14&lt;/b&gt;" not in html
    )  # data, not markup
    short = str(_steps_html(steps[:3]))
    assert short.count("<li ") == 3 and 'start="1"' in short and "earlier" not in short
