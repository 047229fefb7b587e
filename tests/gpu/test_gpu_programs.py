"""dispatch_groups on the real GL context: every group runs once, and a fold into 2-D launches
hardly any empty groups (they cost time on llvmpipe)."""
from __future__ import annotations

import numpy as np
import pytest

from isoscope.core.layout import MAX_GROUPS_PER_DIMENSION
from isoscope.gpu.programs import dispatch_groups

COUNTER = """#version 430
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Counts { uint launched; uint in_range; uint seen[]; };
uniform uint u_groups;
void main() {
    atomicAdd(launched, 1u);
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (group >= u_groups) return;
    atomicAdd(in_range, 1u);
    atomicAdd(seen[group], 1u);
}
"""


@pytest.mark.parametrize("groups", [1, 1000, MAX_GROUPS_PER_DIMENSION, MAX_GROUPS_PER_DIMENSION + 1,
                                    2 * MAX_GROUPS_PER_DIMENSION + 7])
def test_every_group_runs_once_with_few_empty_ones(gl_ctx, groups):
    program = gl_ctx.compute_shader(COUNTER)
    counts = gl_ctx.buffer(np.zeros(2 + groups, np.uint32).tobytes())
    counts.bind_to_storage_buffer(0)
    program["u_groups"].value = groups
    dispatch_groups(program, groups)
    gl_ctx.finish()
    result = np.frombuffer(counts.read(), np.uint32)
    launched, in_range, seen = int(result[0]), int(result[1]), result[2:]
    assert in_range == groups and np.all(seen == 1)
    rows = -(-groups // MAX_GROUPS_PER_DIMENSION)
    assert groups <= launched < groups + rows  # 65,536 groups once launched 131,070
    counts.release()
    program.release()
