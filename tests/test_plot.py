"""``pointat plot``: a take drawn as PNG and HTML, from a BROAD trial (with truth) and a glove's ADC take."""

import base64
import gzip
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from pointat.cli import main
from pointat.devices.glove_sim import GloveSimulator
from pointat.plotting import ADC_COLUMNS, MATPLOTLIB_HINT

pytest.importorskip("matplotlib")
from matplotlib.image import imread  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TRIAL = ROOT / "pointat" / "data" / "01_undisturbed_slow_rotation_A.csv.gz"


def looks_drawn(png: Path) -> tuple[int, int]:
    """A PNG of a plausible size that decodes to a picture with something on it: its height and width."""
    assert 20_000 < png.stat().st_size < 5_000_000
    image = imread(png)
    height, width = image.shape[:2]
    assert height > 600 and width > 800 and image.shape[2] in (3, 4)
    rgb = np.round(image[..., :3] * 255).astype(np.uint32)
    assert rgb.std() > 10  # not one colour
    colours = rgb[..., 0] << 16 | rgb[..., 1] << 8 | rgb[..., 2]
    assert len(np.unique(colours)) > 50  # curves, text and fills, not a blank page
    return height, width


def embeds(html: Path, png: Path) -> None:
    """The page embeds the PNG itself, as base64."""
    match = re.search(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html.read_text(encoding="utf-8"))
    assert match, "no embedded PNG"
    assert base64.b64decode(match.group(1)) == png.read_bytes()


@pytest.fixture(scope="module")
def broad(tmp_path_factory):
    """The vendored BROAD trial, plotted once: its outputs and what the command printed."""
    out = tmp_path_factory.mktemp("broad") / "trial"
    return out, main(["plot", str(TRIAL), "-o", str(out)])


def test_a_broad_trial_is_drawn_with_its_error_against_truth(broad, capsys):
    out, code = broad
    png, html = out.with_suffix(".png"), out.with_suffix(".html")
    assert code == 0
    height, _ = looks_drawn(png)
    embeds(html, png)
    page = html.read_text(encoding="utf-8")
    rms = float(re.search(r'class="rms">([^<°]+)°', page).group(1))
    assert math.isfinite(rms) and 0.0 < rms < 10.0  # (robust tqt on this trial: about 1.6)
    for flag in ("rest", "mag_disturbed", "acc_saturated", "gyro_saturated", "shaking"):
        assert f"flagged {flag}" in page
    assert "56940" in page  # samples


def excerpt(path: Path, rows: int) -> Path:
    """The BROAD trial's first ``rows`` samples, in its format (comment lines and header kept)."""
    with gzip.open(TRIAL, "rt") as src, gzip.open(path, "wt") as dst:
        n = -1
        for line in src:
            dst.write(line)
            n += not line.startswith("#")
            if n == rows:
                break
    return path


def test_no_truth_leaves_the_error_panel_out(tmp_path, capsys):
    take = excerpt(tmp_path / "short.csv.gz", 3000)
    assert main(["plot", str(take)]) == 0  # beside the take, its extensions dropped
    with_truth = (tmp_path / "short.png", tmp_path / "short.html")
    assert capsys.readouterr().out.split() == [str(p) for p in with_truth]
    assert main(["plot", str(take), "--no-truth", "-o", str(tmp_path / "bare")]) == 0
    bare = (tmp_path / "bare.png", tmp_path / "bare.html")
    assert 'class="rms"' in with_truth[1].read_text() and 'class="rms"' not in bare[1].read_text()
    assert looks_drawn(bare[0])[0] < looks_drawn(with_truth[0])[0]  # a panel fewer


def glove_take(path: Path, seconds: float = 4.0) -> Path:
    """A take as patches/record_glove.pat records it: t and the nine raw ADC counts of each mote frame."""
    glove = GloveSimulator(rate_hz=100.0, seed=3)
    lines = ["t," + ",".join(ADC_COLUMNS)]
    for sample in glove.samples(int(seconds * 100)):
        lines.append(",".join([repr(sample.t), *(f"{c}.0" for c in sample.frame.channels)]))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_glove_take_of_adc_counts_is_drawn_without_truth(tmp_path, capsys):
    take = glove_take(tmp_path / "take.csv")
    assert main(["plot", str(take)]) == 0
    png, html = tmp_path / "take.png", tmp_path / "take.html"
    assert capsys.readouterr().out.split() == [str(png), str(html)]
    looks_drawn(png)
    embeds(html, png)
    page = re.sub(r"base64,[^\"]*", "", html.read_text(encoding="utf-8"))  # the words, not the picture
    assert "RMS" not in page and "error" not in page  # no truth, no error panel
    assert "400" in page and "offset samples=150" in page


def test_a_missing_file_or_missing_columns_exit_2_naming_the_file_and_what_is_missing(tmp_path, capsys):
    missing = tmp_path / "nowhere.csv"
    assert main(["plot", str(missing)]) == 2
    err = capsys.readouterr().err
    assert str(missing) in err and "no such file" in err

    quats = tmp_path / "quats.csv"
    quats.write_text("t,qw,qx,qy,qz\n0.0,1,0,0,0\n0.01,1,0,0,0\n")
    assert main(["plot", str(quats)]) == 2
    err = capsys.readouterr().err
    assert str(quats) in err and "gyr_x" in err and "adc_gx" in err

    lost = tmp_path / "lost.csv"  # a glove take without its magnetometer's last channel
    lost.write_text(
        "t," + ",".join(ADC_COLUMNS[:-1]) + "\n" + "0.0" + ",2048" * 8 + "\n0.01" + ",2048" * 8 + "\n"
    )
    assert main(["plot", str(lost)]) == 2
    err = capsys.readouterr().err
    assert str(lost) in err and "adc_mz" in err
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.html"))


def test_without_matplotlib_the_command_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    take = glove_take(tmp_path / "take.csv", seconds=2.0)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib: ImportError
    assert main(["plot", str(take)]) == 2
    assert MATPLOTLIB_HINT in capsys.readouterr().err
    assert MATPLOTLIB_HINT == 'pointat plot needs matplotlib: pip install "pointat[plot]"'
    assert not list(tmp_path.glob("*.png"))
