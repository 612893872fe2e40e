"""Old module paths keep working for one release (issue 32): each flat module of 0.1.0 imports as
the module it now is, with a DeprecationWarning pointing at the importing line; the public
`hapticgraph.features` is the sweeps' features module, without a warning; the engine's runner
answers to its old name with a warning."""
import importlib
import sys
import warnings

import pytest

import hapticgraph


@pytest.mark.parametrize("old", sorted(hapticgraph.MOVED))
def test_an_old_path_is_the_moved_module_with_a_deprecation_warning(old):
    sys.modules.pop(f"hapticgraph.{old}", None)
    with pytest.warns(DeprecationWarning, match=f"hapticgraph.{old} is now {hapticgraph.MOVED[old]}") as caught:
        module = importlib.import_module(f"hapticgraph.{old}")
    assert module is importlib.import_module(hapticgraph.MOVED[old])
    assert module.__spec__.name == hapticgraph.MOVED[old]          # the module keeps its own spec
    assert caught[0].filename != "<frozen importlib._bootstrap>"


def test_the_import_statement_is_blamed():
    sys.modules.pop("hapticgraph.sweep_spec", None)
    with pytest.warns(DeprecationWarning) as caught:
        import hapticgraph.sweep_spec  # noqa: F401
    assert caught[0].filename == __file__


def test_features_is_public_and_warns_nothing():
    sys.modules.pop("hapticgraph.features", None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from hapticgraph.features import register_feature
        import hapticgraph.features as features
    from hapticgraph.sweeps import features as real
    assert features is real and register_feature is real.register_feature
    assert hapticgraph.features is real


def test_the_public_fit_and_sweep_warn_nothing(tmp_path):
    """`hapticgraph.fit` and `.sweep` reach the moved modules by their new names (a missing
    patch fails after the import, with no DeprecationWarning on the way)."""
    sys.modules.pop("hapticgraph.fitting", None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        with pytest.raises(Exception) as fitted:
            hapticgraph.fit(tmp_path / "none.yaml", tmp_path / "none.wav", {})
        with pytest.raises(Exception) as swept:
            hapticgraph.sweep(tmp_path / "none.yaml", tmp_path / "out")
    assert not isinstance(fitted.value, DeprecationWarning) and not isinstance(swept.value, DeprecationWarning)


def test_the_engines_old_session_name_warns():
    from hapticgraph.graph import engine
    with pytest.warns(DeprecationWarning, match="graph.engine.Runner"):
        assert engine.Session is engine.Runner
    with pytest.raises(AttributeError):
        engine.NoSuchName
