// Subgroup-aggregated atomic accumulation of Q-learning targets. The includer
// declares frame_sums[] and frame_counts[] and enables the subgroup, float-atomic
// and (with RLPT_PARTITIONED) partitioned-subgroup extensions.
#ifndef RLPT_RECORD_GLSL
#define RLPT_RECORD_GLSL

// Adds `target` to this frame's sum for `key`, one atomic per distinct key in the
// subgroup: lanes with the same key combine first (subgroupPartitionNV where the
// device has it, a ballot loop otherwise). Call from any subset of lanes.
void record_target(uint key, float target) {
#ifdef RLPT_PARTITIONED
    uvec4 group = subgroupPartitionNV(key);
    float sum = subgroupPartitionedAddNV(target, group);
    uint count = subgroupBallotBitCount(group);
    if (subgroupBallotFindLSB(group) == gl_SubgroupInvocationID) {
        atomicAdd(frame_sums[key], sum);
        atomicAdd(frame_counts[key], count);
    }
#else
    for (;;) {
        uint first = subgroupBroadcastFirst(key);
        if (key == first) {
            float sum = subgroupAdd(target);
            uint count = subgroupBallotBitCount(subgroupBallot(true));
            if (subgroupElect()) {
                atomicAdd(frame_sums[key], sum);
                atomicAdd(frame_counts[key], count);
            }
            break;
        }
    }
#endif
}

#endif
