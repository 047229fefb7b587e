#!/usr/bin/env python3
"""What one load costs a compute shader on this GL: SSBO vs uniform block vs texelFetch vs imageLoad.

The extractor's layout follows from these numbers (shaders/mc_common.glsl): on
llvmpipe an SSBO load is loaded and bounds-checked lane by lane, while imageLoad
and uniform loads are vectorised, so data that passes read often lives in images
and the case table in a uniform block.  Run it again on a new driver or a real
GPU before changing that layout.

Each variant runs one dispatch of N invocations doing 8 dependent-free loads
(XORed into one store, so nothing is optimised away); the figure is the best of
5 runs divided by the loads done.  Two access patterns: "near" (neighbouring
lanes read neighbouring words, as the passes do) and "scattered" (hashed).

    python benchmarks/bench_loads.py [--invocations N]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from isoscope.gpu.context import current_or_standalone

LOADS = 8
GROUP = 64

HEAD = f"""#version 430
layout(local_size_x = {GROUP}) in;
layout(std430, binding = 1) writeonly buffer Out {{ uint result[]; }};
"""

BODY = """
void main() {
    uint id = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * %(group)du + gl_LocalInvocationIndex;
    uint acc = 0u;
    for (uint r = 0u; r < %(loads)du; ++r) {
        uint i = (%(address)s) & %(mask)du;  // a word of the data; in the volume, texel (i>>2 & 127, i>>9 & 127, i>>16)
        acc ^= %(load)s;
    }
    result[id] = acc;
}
"""

ADDRESSES = {"near": "id + r * 896u", "scattered": "(id * 2654435761u) ^ (r * 40503u)"}

# name -> (declarations, load expression of word i)
VARIANTS = {
    "SSBO uint": ("layout(std430, binding = 0) readonly buffer Data { uint data[]; };", "data[i]"),
    "uniform block uvec4 (small table)": ("layout(std140, binding = 0) uniform Table { uvec4 table[256]; };",
                                          "table[i & 255u].x"),
    "texelFetch usampler2D r32ui": ("uniform usampler2D u_words;",
                                    "texelFetch(u_words, ivec2(i & 2047u, i >> 11), 0).x"),
    "imageLoad uimage2D r32ui": ("layout(r32ui, binding = 0) readonly uniform uimage2D u_image;",
                                 "imageLoad(u_image, ivec2(i & 2047u, i >> 11)).x"),
    "texelFetch sampler3D rgba32f": (
        "uniform sampler3D u_volume;",
        "floatBitsToUint(texelFetch(u_volume, ivec3((i >> 2) & 127u, (i >> 9) & 127u, i >> 16), 0).x)"),
    "imageLoad image3D rgba32f": (
        "layout(rgba32f, binding = 0) readonly uniform image3D u_volume_image;",
        "floatBitsToUint(imageLoad(u_volume_image, ivec3((i >> 2) & 127u, (i >> 9) & 127u, i >> 16)).x)"),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--invocations", type=int, default=1 << 21,
                        help="a power of two, at least 2^16 (default 2^21)")
    N = parser.parse_args().invocations
    if N < 1 << 16 or N & (N - 1):
        parser.error("--invocations must be a power of two, at least 65536")
    ctx = current_or_standalone()
    rng = np.random.default_rng(0)
    words = rng.integers(0, 2**32, N, dtype=np.uint32)
    data = ctx.buffer(words.tobytes())
    table = ctx.buffer(words[:1024].tobytes())
    out = ctx.buffer(reserve=N * 4)
    image = ctx.texture((2048, N // 2048), 1, words.tobytes(), dtype="u4")
    samples = rng.standard_normal(N).astype(np.float32)  # N / 4 texels of 4 samples
    volume = ctx.texture3d((128, 128, N >> 16), 4, samples.tobytes(), dtype="f4")
    print(f"GL renderer: {ctx.info['GL_RENDERER']}")
    print(f"{N} invocations x {LOADS} loads; ns per load (best of 5)\n")
    print("| load | near | scattered |\n|---|---:|---:|")
    for name, (declarations, load) in VARIANTS.items():
        row = []
        for address in ADDRESSES.values():
            source = HEAD + declarations + BODY % {"group": GROUP, "loads": LOADS, "address": address,
                                                   "mask": N - 1, "load": load}
            program = ctx.compute_shader(source)
            data.bind_to_storage_buffer(0)
            out.bind_to_storage_buffer(1)
            table.bind_to_uniform_block(0)
            is_volume = "u_volume" in declarations
            texture = volume if is_volume else image
            texture.use(0)
            texture.bind_to_image(0, read=True, write=False)
            for uniform in ("u_words", "u_volume"):
                if uniform in program:
                    program[uniform].value = 0
            best = float("inf")
            for _ in range(5):
                ctx.finish()
                start = time.perf_counter()
                program.run(N // GROUP // 2, 2)
                ctx.finish()
                best = min(best, time.perf_counter() - start)
            row.append(best * 1e9 / (N * LOADS))
            program.release()
        print(f"| {name} | {row[0]:.2f} | {row[1]:.2f} |")


if __name__ == "__main__":
    main()
