"""The REST client's copy of the finished trial states stays the catalog's (it is kept apart so the client
does not import the catalog)."""

from gaitcap.services.catalog.states import FINISHED as CATALOG_FINISHED
from gaitcap.services.ops.auto_trial import FINISHED


def test_the_clients_finished_states_are_the_catalogs():
    assert sorted(FINISHED) == sorted(str(s) for s in CATALOG_FINISHED)
