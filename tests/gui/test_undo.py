"""The undo stack: steps on the project survive another pair shown, steps on the pair shown do not."""

import random

import pytest

from usvips.gui.undo import Command, UndoStack


@pytest.mark.parametrize("seed", range(20))
def test_forgetting_the_pair_steps_keeps_the_project_steps_in_their_order(seed):
    rng = random.Random(seed)
    stack, state, heard = UndoStack(), [], []
    stack.changed.connect(lambda: heard.append(1))
    kinds = [rng.random() < 0.5 for _ in range(rng.randint(1, 12))]  # True: bound to the pair shown
    for i, bound in enumerate(kinds):
        stack.push(Command(f"step {i}", lambda i=i: state.append(i), lambda i=i: state.remove(i), pair_bound=bound))
    for _ in range(rng.randint(0, len(kinds))):  # some undone: on the redo stack
        stack.undo()
    done = [i for i in state]
    undone = [i for i in range(len(kinds)) if i not in done]
    before = len(heard)
    stack.forget_pair_steps()
    assert len(heard) == before + (1 if any(kinds) else 0)  # said only when something was forgotten
    project_done = [i for i in done if not kinds[i]]
    project_undone = [i for i in undone if not kinds[i]]
    # undo walks back through the project steps only, newest first; redo forwards, oldest first
    while stack.undo() is not None:
        pass
    assert state == [i for i in done if kinds[i]]  # the pair's steps are no longer undone
    redone = []
    while (label := stack.redo()) is not None:
        redone.append(int(label.split()[1]))
    assert redone == project_done + project_undone


def test_a_step_refused_as_stale_is_dropped_and_any_other_refusal_stays_to_try_again():
    """Undo of a step another annotator has edited over since can never be made: it is dropped (the next
    undo takes back the step before); a step refused otherwise (the store busy) stays where it was."""
    from usvips.core.errors import UsvipsError
    from usvips.store.records import StaleEditError

    stack, state, heard, refusal = UndoStack(), [], [], []

    def undo(i: int) -> None:
        if refusal:
            raise refusal.pop()
        state.remove(i)

    for i in range(3):
        stack.push(Command(f"step {i}", lambda i=i: state.append(i), lambda i=i: undo(i)))
    stack.changed.connect(lambda: heard.append(1))
    refusal.append(UsvipsError("the project is busy"))
    with pytest.raises(UsvipsError, match="busy"):
        stack.undo()
    assert stack.undo_label == "step 2" and state == [0, 1, 2] and stack.redo_label is None and not heard
    refusal.append(StaleEditError("object 2 was changed by someone else"))
    with pytest.raises(StaleEditError):
        stack.undo()
    assert stack.undo_label == "step 1" and stack.redo_label is None and heard == [1] and state == [0, 1, 2]
    assert stack.undo() == "step 1" and state == [0, 2] and stack.redo() == "step 1" and state == [0, 2, 1]
