"""Loading and validating networks (Chuang 2011, Sec. 3.3, Fig. 10)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bayesnets import parse_table, read_network, write_network
from bayesnets.errors import (
    BindingError,
    CyclicNetworkError,
    InconsistentStatesError,
    InvalidWeightError,
    MissingParentCombinationError,
    NetworkDefinitionError,
    TableFormatError,
    UnknownParentError,
)
from tests.bayesnets.conftest import TOY_CONFIG, TOY_TABLES, write_folder

# Chuang 2011, Fig. 10: the _LSTYPE table, tab-separated, with the weight total (174) in
# the last header cell. Parent tables added here so the network is complete.
FIGURE_10 = """_LSTYPE\tHAS_MEDIAN\tWIDE_ROAD\t174
C\tF\tF\t0
DS\tF\tF\t15
DSS\tF\tF\t15
DSCS\tF\tF\t0
DSC\tF\tF\t0
SS\tF\tF\t20
C\tF\tT\t0
DS\tF\tT\t10
DSS\tF\tT\t10
DSCS\tF\tT\t0
DSC\tF\tT\t0
SS\tF\tT\t3
C\tT\tF\t10
DS\tT\tF\t15
DSS\tT\tF\t15
DSCS\tT\tF\t5
DSC\tT\tF\t5
SS\tT\tF\t5
C\tT\tT\t5
DS\tT\tT\t10
DSS\tT\tT\t10
DSCS\tT\tT\t10
DSC\tT\tT\t10
SS\tT\tT\t1
"""


def test_chuang_figure_10_table_normalised_per_parent_combination(tmp_path: Path) -> None:
    # Published weights (Chuang 2011, Fig. 10); rows are normalised per parent combination,
    # so P(SS | HAS_MEDIAN=F, WIDE_ROAD=F) = 20 / (15 + 15 + 20) = 0.4 exactly.
    folder = write_folder(
        tmp_path / "fig10",
        {
            "_LSTYPE.csv": FIGURE_10,
            "HAS_MEDIAN.csv": "HAS_MEDIAN,weight\nT,1\nF,1\n",
            "WIDE_ROAD.csv": "WIDE_ROAD,weight\nT,1\nF,1\n",
        },
    )
    net = read_network(folder)
    table = net.tables["_LSTYPE"]
    states = net.states
    ss = states["_LSTYPE"].index("SS")
    f_median, f_wide = states["HAS_MEDIAN"].index("F"), states["WIDE_ROAD"].index("F")
    t_median, t_wide = states["HAS_MEDIAN"].index("T"), states["WIDE_ROAD"].index("T")
    assert table[ss, f_median, f_wide] == pytest.approx(0.4, abs=1e-12)
    assert table[ss, t_median, t_wide] == pytest.approx(1 / 46, abs=1e-12)
    np.testing.assert_allclose(table.sum(axis=0), 1.0, atol=1e-12)


def test_toy_network_loads_in_topological_order(toy_folder: Path) -> None:
    net = read_network(toy_folder)
    order = net.variables
    for child in order:
        for parent in net.parents[child]:
            assert order.index(parent) < order.index(child)
    assert net.name == "toy"
    assert net.field_of("B") is None  # hidden
    assert net.tables["D"][:, net.states["C"].index("c2")].tolist() == [0.0, 1.0]


def _broken(tmp_path: Path, name: str, text: str) -> Path:
    return write_folder(tmp_path / "net", {**TOY_TABLES, name: text}, TOY_CONFIG)


def test_cycle_is_named(tmp_path: Path) -> None:
    # A now depends on D: A -> C -> D -> A.
    folder = _broken(tmp_path, "A.csv", "A,D,weight\na0,T,1\na1,T,1\na2,T,1\na0,F,1\n")
    with pytest.raises(CyclicNetworkError) as info:
        read_network(folder)
    message = str(info.value)
    assert "A.csv" in message and "line 1" in message
    assert "A -> " in message and message.count("A") >= 2  # the cycle is closed


def test_missing_parent_combination_is_named(tmp_path: Path) -> None:
    # D has no row at all for C = c2.
    folder = _broken(tmp_path, "D.csv", "D,C,weight\nT,c0,9\nF,c0,1\nT,c1,5\nF,c1,5\n")
    with pytest.raises(MissingParentCombinationError, match=r"D\.csv.*C=c2.*no row"):
        read_network(folder)


def test_all_zero_parent_combination_names_rows(tmp_path: Path) -> None:
    folder = _broken(
        tmp_path, "D.csv", "D,C,weight\nT,c0,9\nF,c0,1\nT,c1,5\nF,c1,5\nT,c2,0\nF,c2,0\n"
    )
    with pytest.raises(MissingParentCombinationError, match=r"D\.csv.*C=c2.*lines \[6, 7\]"):
        read_network(folder)


def test_inconsistent_parent_state_names_file_and_line(tmp_path: Path) -> None:
    # 'c9' is not a state of C.
    folder = _broken(
        tmp_path,
        "D.csv",
        "D,C,weight\nT,c0,9\nF,c0,1\nT,c1,5\nF,c1,5\nT,c2,0\nF,c2,1\nT,c9,1\n",
    )
    with pytest.raises(
        InconsistentStatesError, match=r"D\.csv, line 8: parent C has no state 'c9'"
    ):
        read_network(folder)


@pytest.mark.parametrize("weight", ["-1", "nan", "inf", "lots"])
def test_bad_weight_names_file_and_line(tmp_path: Path, weight: str) -> None:
    folder = _broken(tmp_path, "A.csv", f"A,weight\na0,5\na1,{weight}\na2,2\n")
    with pytest.raises(InvalidWeightError, match=r"A\.csv, line 3: weight"):
        read_network(folder)


def test_unknown_parent_names_file(tmp_path: Path) -> None:
    folder = _broken(tmp_path, "D.csv", "D,X,weight\nT,x,1\nF,x,1\n")
    with pytest.raises(UnknownParentError, match=r"D\.csv, line 1: parent 'X'"):
        read_network(folder)


def test_duplicate_row_names_both_lines(tmp_path: Path) -> None:
    folder = _broken(tmp_path, "A.csv", "A,weight\na0,5\na1,3\na0,2\n")
    with pytest.raises(TableFormatError, match=r"A\.csv, line 4: duplicate row a0.*line 2"):
        read_network(folder)


def test_wrong_cell_count_names_line() -> None:
    with pytest.raises(TableFormatError, match=r"t\.csv, line 3: 2 cells"):
        parse_table("B,A,weight\nb0,a0,1\nb1,1\n", source="t.csv")


def test_bad_header_and_empty_table() -> None:
    with pytest.raises(TableFormatError, match="line 1"):
        parse_table("A,B,C\na,b,1\n", source="t.csv")
    with pytest.raises(TableFormatError, match="empty table"):
        parse_table("# only a comment\n", source="t.csv")


def test_binding_errors_name_network_toml(tmp_path: Path) -> None:
    config = TOY_CONFIG + '\n[variables.Z]\nfield = "z"\n'
    folder = write_folder(tmp_path / "net", TOY_TABLES, config)
    with pytest.raises(BindingError, match=r"network\.toml.*\[variables\.Z\] names no table"):
        read_network(folder)
    config = TOY_CONFIG.replace('kind = "bool"', 'kind = "int"')
    folder = write_folder(tmp_path / "net2", TOY_TABLES, config)
    with pytest.raises(BindingError, match=r"\[variables\.D\].*not a number"):
        read_network(folder)


def test_missing_folder_and_no_tables(tmp_path: Path) -> None:
    with pytest.raises(NetworkDefinitionError, match="not a network folder"):
        read_network(tmp_path / "absent")
    (tmp_path / "empty").mkdir()
    with pytest.raises(NetworkDefinitionError, match=r"no \*\.csv"):
        read_network(tmp_path / "empty")


def test_write_read_round_trip(toy_folder: Path, tmp_path: Path) -> None:
    net = read_network(toy_folder)
    copy = read_network(write_network(net, tmp_path / "copy"))
    assert copy.variables == net.variables
    assert copy.bindings == net.bindings
    for name in net.variables:
        np.testing.assert_allclose(copy.tables[name], net.tables[name], rtol=1e-5)
