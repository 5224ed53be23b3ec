"""Work run in a child process that exits after it: its value, its error and its log records come back."""

import logging
import math
import os

import pytest
from gaitcap.services.processing.apart import call_apart


def test_the_value_comes_back_and_the_work_runs_in_another_process():
    assert call_apart(math.sqrt, 16.0, what="a root") == 4.0
    assert call_apart(os.getpid, what="its process id") != os.getpid()


def test_the_childs_error_is_raised_here_with_its_type_and_message():
    with pytest.raises(ValueError, match="invalid literal"):
        call_apart(int, "not a number", what="a parse")


def test_what_the_child_logged_is_logged_here_under_its_logger(caplog):
    caplog.set_level(logging.INFO)
    call_apart(logging.getLogger("gaitcap.kinematics.test").warning, "knee rests on its bound in %d frames", 15,
               what="a warning")
    assert [(r.name, r.levelno, r.getMessage()) for r in caplog.records] == [
        ("gaitcap.kinematics.test", logging.WARNING, "knee rests on its bound in 15 frames")]


def test_a_child_that_dies_without_an_answer_is_an_error_naming_the_work():
    with pytest.raises(RuntimeError, match=r"t9 refined kinematics: its process died \(exit code 3\)"):
        call_apart(os._exit, 3, what="t9 refined kinematics")


def test_the_child_sees_the_callers_environment_as_it_is_now(monkeypatch):
    call_apart(math.sqrt, 1.0, what="the server started")
    monkeypatch.setenv("GAITCAP_APART_TEST", "set after the server started")
    assert call_apart(os.getenv, "GAITCAP_APART_TEST", what="an environment variable") == \
        "set after the server started"
