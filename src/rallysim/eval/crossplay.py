"""Cross-play: every pair of a list of competitive players, a matrix of who beats whom.

``crossplay(names, games, seed, max_decisions)`` plays each unordered pair once with
``play_games`` (which already alternates the sides, so a pair needs no second match with the
roles swapped) and returns a JSON-able dict:

- ``point_win_rate[i][j]``: player i's share of the points against player j, ``{value, low,
  high}`` (95 % bootstrap over games); the mirror cell ``[j][i]`` is ``1 - value`` with the
  interval mirrored, the diagonal is ``None``;
- ``game_win_rate[i][j]``: likewise over finished games (``None`` where no game finished);
- ``mean_rally[i][j]``: hits per point, the same both ways;
- ``pairs``: each pair's full ``summarise``; ``ratings``: OpenSkill ratings from all the
  points played (``rallysim.eval.ratings.rate_points``: each point a match, the pairs'
  points interleaved), ``table``: the players best ordinal first.

``play_pairs`` and ``matrix`` are its two halves, for a matrix of chosen pairs (the
competitive study's: the ladder, each seed's snapshots against the ladder and each other);
``submatrix`` cuts a result down to some players. ``heatmap(result, path)`` draws the
point-win matrix as a PNG (needs matplotlib).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.eval.agents import agent
from rallysim.eval.competitive import DEFAULT_MAX_DECISIONS, Games, play_games, summarise
from rallysim.jsondoc import jsonable

Say = Callable[[str], None]
Cell = dict[str, float] | None

# the heat map's layout in inches (a cell; the margins for names, title and colour bar) at DPI:
# the PNG's pixel size follows from the number of players alone (heatmap_size)
CELL_IN, LEFT_IN, RIGHT_IN, BOTTOM_IN, TOP_IN, DPI = 1.3, 1.9, 1.1, 1.3, 0.6, 100


def crossplay(names: list[str], games: int, seed: int = 0,
              max_decisions: int = DEFAULT_MAX_DECISIONS, shuttle: str = "paper",
              say: Say | None = None, low: str = "pretrained", player: str = "simple"
              ) -> dict[str, Any]:
    """Every pair of ``names`` plays ``games`` games (see the module), as players of the kind
    ``player``; hierarchical players swing with the low level ``low``; ``say`` gets a progress
    line before and after each pair."""
    names = list(names)
    check_names(names, games, low, player)
    played = play_pairs(names, list(combinations(names, 2)), games, seed, max_decisions,
                        shuttle, say, low, player=player)
    return matrix(names, played, games, seed, max_decisions, shuttle, low, player=player)


def check_names(names: list[str], games: int, low: str = "pretrained",
                player: str = "simple") -> None:
    """Refuse (ValueError) a cross-play that cannot run, before any game."""
    if len(names) < 2:
        raise ValueError(f"cross-play needs at least two players, got {len(names)}")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"each player may appear once in cross-play; repeated: {repeated}")
    if not isinstance(games, int) or games < 1:
        raise ValueError(f"games must be a positive integer, got {games!r}")
    for name in names:
        agent(name, player, low=low)  # a bad name fails here, before any game


def play_pairs(names: list[str], pairs: list[tuple[str, str]], games: int, seed: int = 0,
               max_decisions: int = DEFAULT_MAX_DECISIONS, shuttle: str = "paper",
               say: Say | None = None, low: str = "pretrained",
               played: dict[tuple[str, str], Games] | None = None, player: str = "simple"
               ) -> dict[tuple[str, str], Games]:
    """The games of each pair ``(a, b)`` of ``pairs`` (``a`` first), every pair with the same
    ``seed``; a pair already in ``played`` (either way round) is taken from there, not played
    again. Returns ``played`` with the new pairs added."""
    played = {} if played is None else played
    todo = [(a, b) for a, b in pairs if (a, b) not in played and (b, a) not in played]
    for k, (a, b) in enumerate(todo, 1):
        start = time.perf_counter()
        if say:
            say(f"[crossplay] pair {k}/{len(todo)}: {a} vs {b}, {games} games ...")
        # fresh agents per pair: each pair's games depend on the seed alone, not on the order
        g = played[a, b] = play_games(agent(a, player, low=low), agent(b, player, low=low),
                                      games, seed, shuttle, max_decisions)
        if say:
            say(f"[crossplay] pair {k}/{len(todo)}: {a} won {g.point_win_rate:.2f} of "
                f"{int(g.points.sum())} points, {int((g.winner >= 0).sum())}/{games} games "
                f"finished, {time.perf_counter() - start:.0f} s")
    return played


def matrix(names: list[str], played: dict[tuple[str, str], Games], games: int, seed: int = 0,
           max_decisions: int = DEFAULT_MAX_DECISIONS, shuttle: str = "paper",
           low: str = "pretrained", ratings: Any = None, player: str = "simple"
           ) -> dict[str, Any]:
    """``crossplay``'s result from the games ``played`` (``(a, b)``: a first) between
    ``names``; a pair with no games has ``None`` cells and no entry in ``pairs``. The
    ratings are ``ratings`` (a ``Ratings``) when given, else those of all the points played
    (``rate_points``, every player moving)."""
    # here, not at the top: openskill is in the train extra, and two players' games (which
    # import this module) must not need it
    from rallysim.eval.ratings import Ratings, rate_points

    n = len(names)
    points: list[list[Cell]] = [[None] * n for _ in range(n)]
    wins: list[list[Cell]] = [[None] * n for _ in range(n)]
    rally: list[list[Cell]] = [[None] * n for _ in range(n)]
    pairs, matches = [], []
    for i, j in combinations(range(n), 2):
        a, b = names[i], names[j]
        if (a, b) in played:
            g = played[a, b]
        elif (b, a) in played:
            g = _swap(played[b, a])
        else:
            continue
        s = summarise(g, seed=seed)
        matches.append((a, b, g))
        points[i][j], points[j][i] = _cell(s["point_win_rate"]), _mirror(s["point_win_rate"])
        wins[i][j], wins[j][i] = _cell(s["game_win_rate"]), _mirror(s["game_win_rate"])
        rally[i][j] = rally[j][i] = _cell(s["mean_rally"])
        pairs.append({"a": a, "b": b, **jsonable(s)})
    if ratings is None:
        ratings = Ratings()
        rate_points(ratings, matches)
    return {"players": names, "games": games, "seed": seed, "max_decisions": max_decisions,
            "shuttle": shuttle, "low": low, "player": player, "point_win_rate": points,
            "game_win_rate": wins, "mean_rally": rally, "pairs": pairs,
            "ratings": ratings.to_json(), "table": ratings.table(names)}


def submatrix(result: dict[str, Any], names: list[str]) -> dict[str, Any]:
    """``result`` (``crossplay`` or ``matrix``) cut down to the players ``names``."""
    index = [result["players"].index(n) for n in names]
    cut = {k: [[result[k][i][j] for j in index] for i in index]
           for k in ("point_win_rate", "game_win_rate", "mean_rally")}
    keep = set(names)
    return {**result, **cut, "players": list(names),
            "pairs": [p for p in result["pairs"] if p["a"] in keep and p["b"] in keep],
            "table": [r for r in result["table"] if r["name"] in keep]}


def _swap(g: Games) -> Games:
    """The games seen from the other side."""
    return Games(points=g.points[:, ::-1].copy(), winner=np.where(g.winner >= 0, 1 - g.winner,
                                                                      -1),
                 decisions=g.decisions, lets=g.lets, point_game=g.point_game,
                 point_hits=g.point_hits, point_a_won=~g.point_a_won)


def _cell(e: dict[str, float]) -> Cell:
    """An estimate as a JSON cell: None when undefined (NaN is no JSON)."""
    return None if not math.isfinite(e["value"]) else {
        k: (v if math.isfinite(v) else None) for k, v in e.items()}


def _mirror(e: dict[str, float]) -> Cell:
    """The other side's share: 1 - value, and the interval mirrored (low <-> high)."""
    return _cell({"value": 1.0 - e["value"], "low": 1.0 - e["high"], "high": 1.0 - e["low"]})


def heatmap_size(n_players: int) -> tuple[int, int]:
    """The heat map's (width, height) in pixels for ``n_players``."""
    side = CELL_IN * n_players
    return (round((LEFT_IN + side + RIGHT_IN) * DPI), round((BOTTOM_IN + side + TOP_IN) * DPI))


def heatmap(result: dict[str, Any], path: str | Path,
            labels: dict[str, str] | None = None, title: str | None = None) -> Path:
    """Draw ``crossplay``'s point-win matrix (row vs column) as a PNG at ``path``; each cell
    reads "0.73\\n[0.68, 0.78]" ("–": not played). ``labels`` names players on the axes
    (default: the name, or an exported policy's file name); ``title`` goes before the
    title's usual text. Needs matplotlib (the ``train`` extra)."""
    # a bare Figure (Agg canvas), not pyplot: no global backend switched, no figure left open
    from matplotlib.figure import Figure

    names, matrix = result["players"], result["point_win_rate"]
    n = len(names)
    values = np.array([[np.nan if c is None else c["value"] for c in row] for row in matrix])
    width, height = heatmap_size(n)
    w_in, h_in, side = width / DPI, height / DPI, CELL_IN * n
    fig = Figure(figsize=(w_in, h_in), dpi=DPI)
    # fixed axes in inches, no tight layout or bbox="tight": those would make the pixel size
    # depend on the names' lengths
    ax = fig.add_axes((LEFT_IN / w_in, BOTTOM_IN / h_in, side / w_in, side / h_in))
    bar = fig.add_axes(((LEFT_IN + side + 0.2) / w_in, BOTTOM_IN / h_in, 0.2 / w_in,
                        side / h_in))
    image = ax.imshow(values, cmap="RdBu", vmin=0.0, vmax=1.0)
    ticks = [(labels or {}).get(name) or _label(name) for name in names]
    ax.set_xticks(range(n), ticks, rotation=30, ha="right")
    ax.set_yticks(range(n), ticks)
    ax.set_xlabel("column player")
    ax.set_ylabel("row player")
    what = f"point-win rate of row vs column ({result['games']} games per pair)"
    ax.set_title(what if title is None else f"{title}: {what}", fontsize=9)
    for i in range(n):
        for j in range(n):
            cell = matrix[i][j]
            text = "–" if cell is None else _cell_text(cell)
            dark = cell is not None and abs(cell["value"] - 0.5) > 0.3
            ax.text(j, i, text, ha="center", va="center", fontsize=8,
                    color="white" if dark else "black")
    fig.colorbar(image, cax=bar)
    path = Path(path)
    fig.savefig(path, dpi=DPI, format="png")
    return path


def _cell_text(cell: dict[str, float]) -> str:
    low, high = cell["low"], cell["high"]
    interval = "" if low is None or high is None else f"\n[{low:.2f}, {high:.2f}]"
    return f"{cell['value']:.2f}{interval}"


def _label(name: str) -> str:
    """A player's name on the axes: an exported policy's file name, not its whole path."""
    return Path(name).name if "/" in name else name
