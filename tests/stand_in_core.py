"""A stand-in plant core for the wrapper tests: one cycle per step, every state counts the steps
taken, the input is only latched; the encoder channels (if asked) show the count's low bits and
each converter's code port (if asked) its low 12 bits. The wrappers around it are the real ones."""


def stand_in_core(plant, uw: int, w: int, name: str = "tiny_core", encoders: bool = False,
                  codes: bool = False) -> str:
    """Verilog of the stand-in core ``name`` for ``plant`` (a plant interface): input ``uw``
    bits wide, states ``w`` bits."""
    channels = [c for sensor in plant.sensors if not sensor.is_adc for c in sensor.channels] if encoders else []
    converters = [s for s in plant.sensors if s.is_adc] if codes else []
    enc = "".join(f"    output wire {e},\n" for e in channels)
    outs = "".join(f"    output wire signed [{w - 1}:0] {p},\n" for p in plant.outputs)
    ports = "".join(f"    output wire signed [31:0] {s.code_port},\n" for s in converters)
    assigns = "".join(f"    assign {p} = s;\n" for p in plant.outputs)
    assigns += "".join(f"    assign {e} = s[{i}];\n" for i, e in enumerate(channels))
    assigns += "".join(f"    assign {s.code_port} = {{20'd0, s[11:0]}};\n" for s in converters)
    inp = plant.input.name
    return f"""`default_nettype none
module {name} (
    input  wire clk,
    input  wire rst,
    input  wire step,
    output wire ready,
    input  wire signed [{uw - 1}:0] {inp},
{outs}{enc}{ports}    output wire overflow
);
    reg [{w - 1}:0] s;
    reg [{uw - 1}:0] u_seen;
    always @(posedge clk) begin
        if (rst) begin
            s <= {w}'d0;
            u_seen <= {uw}'d0;
        end else if (step) begin
            s <= s + {w}'d1;
            u_seen <= {inp};
        end
    end
    assign ready = 1'b1;
{assigns}    assign overflow = 1'b0;
    wire [{uw - 1}:0] u_seen_unused = u_seen;
endmodule
`default_nettype wire
"""


# A Verilog testbench's side of the RAPTOR local bus: its signals, then one-cycle write and read
# strobes (w, r) and a read printed as "R NAME value" (show), for the wrapper tests
RAPTOR_SIGNALS = """    reg  [7:0]  addr = 8'd0;
    reg  [31:0] wdata = 32'd0;
    reg         wr = 1'b0, rd = 1'b0;
    wire [31:0] rdata;
    wire        ack;
"""
RAPTOR_TASKS = """    reg  [31:0] q;
    task w(input [7:0] a, input [31:0] d);
        begin @(negedge clk); addr = a; wdata = d; wr = 1'b1; @(negedge clk); wr = 1'b0; end
    endtask
    task r(input [7:0] a, output [31:0] d);
        begin @(negedge clk); addr = a; rd = 1'b1; @(negedge clk); rd = 1'b0; d = rdata; end
    endtask
    task show(input [8*16-1:0] name, input [7:0] a);
        begin r(a, q); $display("R %0s %h", name, q); end
    endtask
"""
