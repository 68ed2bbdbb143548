"""Tiny designs for the synthesis tests, whose mapping is known without pendc, written into a
folder as `pendc build` writes one (the Verilog and a report.json), which is all
`pendc report synth` reads."""

import json
from pathlib import Path

# a registered signed product: one 18x18 is one MULT18X18D on ECP5, one MULT18X18 on Gowin
MAC = """module {top} (input wire clk, input wire signed [{wa}:0] a, input wire signed [{wb}:0] b,
                   output reg signed [{wy}:0] y);
    reg signed [{wa}:0] ra;
    reg signed [{wb}:0] rb;
    always @(posedge clk) begin
        ra <= a;
        rb <= b;
        y <= ra * rb;
    end
endmodule
"""


def mac(wa: int = 18, wb: int = 18, top: str = "mac") -> str:
    """The Verilog of a ``wa`` x ``wb`` bit registered signed product, module ``top``."""
    return MAC.format(top=top, wa=wa - 1, wb=wb - 1, wy=wa + wb - 1)


def build_folder(tmp_path: Path, name: str, text: str, top: str, ii: int = 3, **report) -> Path:
    """``tmp_path/name`` holding ``text`` as ``<top>.v`` and a report.json naming ``top`` and
    ``ii`` (plus ``report``'s keys: an estimate's ``resources``, the time step ``dt``)."""
    d = tmp_path / name
    d.mkdir()
    (d / f"{top}.v").write_text(text)
    (d / "report.json").write_text(json.dumps({"top": top, "ii": ii, **report}))
    return d
