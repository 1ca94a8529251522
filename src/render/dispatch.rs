//! How a frame's work is dispatched: which pixel rows each dispatch of
//! `pathtrace.comp` traces, by which kernel, and the workgroup's shape.

use crate::guide::RecordSchedule;
use crate::shared;

/// One dispatch of `pathtrace.comp` in a frame: which of the two guided kernels
/// runs it and which pixel rows it traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowDispatch {
    /// The kernel that records Q-learning targets (else the one without that code).
    pub recording: bool,
    /// The kernel's `rows` push constant: `ROWS_*` mode | phase << 8 | stride << 16.
    pub rows: u32,
    /// Workgroup rows to dispatch.
    pub groups_y: u32,
}

/// The dispatches that trace frame `frame` (frames traced before it) of an image
/// `height` rows high: every row once, the rows whose paths record their targets
/// (`schedule`, with guiding) by the recording kernel, the others by the kernel
/// without recording. Without guiding, and past the first frames (whose rows
/// take turns at recording, `RecordSchedule::records_frame`), one dispatch of all
/// rows: a second dispatch costs a small image about one path's latency.
pub fn frame_dispatches(schedule: Option<&RecordSchedule>, frame: u32, height: u32) -> Vec<RowDispatch> {
    let all = |recording| vec![RowDispatch { recording, rows: shared::ROWS_ALL, groups_y: height }];
    let Some(schedule) = schedule else { return all(false) };
    if let Some(records) = schedule.records_frame(frame) {
        return all(records);
    }
    let stride = schedule.stride(frame);
    if stride == 1 {
        return all(true);
    }
    // Rows y with (y + frame) % stride == 0.
    let phase = (stride - frame % stride) % stride;
    let blocks = height.div_ceil(stride);
    let mut d = Vec::with_capacity(2);
    if height > phase {
        d.push(RowDispatch {
            recording: true,
            rows: shared::ROWS_PHASE | phase << 8 | stride << 16,
            groups_y: (height - phase).div_ceil(stride),
        });
    }
    d.push(RowDispatch {
        recording: false,
        rows: shared::ROWS_NOT_PHASE | phase << 8 | stride << 16,
        groups_y: blocks * (stride - 1),
    });
    d
}

/// The pixel row that workgroup row `g` of a dispatch traces (`glsl/pathtrace.comp`
/// `pixel_row`); rows at or past the image's height trace nothing.
pub fn pixel_row(g: u32, rows: u32) -> u32 {
    let (mode, phase, stride) = (rows & 0xff, (rows >> 8) & 0xff, rows >> 16);
    match mode {
        shared::ROWS_PHASE => g * stride + phase,
        shared::ROWS_NOT_PHASE => (g / (stride - 1)) * stride + (phase + 1 + g % (stride - 1)) % stride,
        _ => g,
    }
}

/// Pixels per workgroup of the path-tracing kernel, its `local_size_z`
/// (`SPEC_PIXELS_PER_GROUP`), for a scene of the material kinds `scene_kinds`
/// (`RenderParams::scene_kinds`): 4 for the recording guided kernel of scenes with
/// mirror, glass, glossy, conductor or coated materials, 2 for every other kernel.
/// Smaller groups free an SM's slots sooner after their longest path; the
/// recording kernel that carries the glass and GGX code was slower with 2
/// (docs/ARCHITECTURE.md, "Workgroups").
pub fn pixels_per_group(recording: bool, scene_kinds: u32) -> u32 {
    let lobes = [
        shared::MAT_SPECULAR,
        shared::MAT_DIELECTRIC,
        shared::MAT_GLOSSY,
        shared::MAT_CONDUCTOR,
        shared::MAT_ROUGH_DIELECTRIC,
        shared::MAT_COATED,
    ]
    .iter()
    .fold(0, |k, m| k | 1 << m);
    if recording && scene_kinds & lobes != 0 {
        shared::PIXELS_PER_GROUP
    } else {
        shared::PIXELS_PER_GROUP_SMALL
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The recording kernels of door and seed-exp1 (diffuse walls and lamps) run 2
    /// pixels per workgroup, those of seed-exp2 and exp3 (a mirror, glass and
    /// GGX ball) 4; every kernel that does not record 2 everywhere.
    #[test]
    fn only_recording_kernels_with_lobes_take_the_large_groups() {
        for (name, recording) in [("door", 2), ("seed-exp1", 2), ("seed-exp2", 4), ("seed-exp3", 4)] {
            let s = crate::scene::Scene::load(format!("{}/scenes/{name}.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
            let p = crate::prepared::PreparedScene::new(&s, &crate::options::RenderOptions::from_scene(&s)).unwrap();
            assert_eq!(pixels_per_group(true, p.params.scene_kinds), recording, "{name}");
            assert_eq!(pixels_per_group(false, p.params.scene_kinds), 2, "{name}");
        }
    }

    /// Each frame's dispatches trace every pixel row exactly once, the rows that
    /// record (`RecordSchedule::records`) by the recording kernel and no others,
    /// through every stride of a schedule.
    #[test]
    fn frame_dispatches_trace_every_row_once() {
        // 102.4 paths per entry per frame: strides 8, 16 and 32 from frames 8, 32
        // and 192.
        let s = RecordSchedule::new(1600, 1000, 1);
        let strides = [7, 8, 31, 32, 191, 192].map(|f| s.stride(f));
        assert_eq!(strides, [1, 8, 8, 16, 16, 32], "{s:?}");
        for guided in [false, true] {
            let schedule = guided.then_some(&s);
            for frame in (0..120).chain(180..260) {
                for height in 1..=3 * shared::RECORD_MAX_STRIDE + 1 {
                    let mut traced = vec![0u32; height as usize];
                    for d in frame_dispatches(schedule, frame, height) {
                        for g in 0..d.groups_y {
                            let y = pixel_row(g, d.rows);
                            if y >= height {
                                continue;
                            }
                            traced[y as usize] += 1;
                            let records = guided && s.records(frame, y);
                            assert_eq!(
                                d.recording, records,
                                "guided {guided}, frame {frame}, height {height}, row {y}"
                            );
                        }
                    }
                    assert!(
                        traced.iter().all(|&n| n == 1),
                        "guided {guided}, frame {frame}, height {height}: rows traced {traced:?}"
                    );
                }
            }
        }
    }
}
