//! `--time T` on the CPU ends at T: the frame that would end past it is cut
//! short at it (`CpuRenderer::render_frame_within`). Alone in its test binary,
//! so that no other test shares the cores while it measures wall time.

mod common;

use common::{options, scene};
use rlpt::cpu::CpuRenderer;
use rlpt::prepared::PreparedScene;
use rlpt::session::{Budget, Session};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// How far from T a timed render may end: a pass of one sample per pixel
/// predicted to fit that ran slower on a loaded machine, the learning pass after
/// the last frame, and the session's own work between frames.
const MARGIN_S: f64 = 0.15;

/// The scene at the smallest size of `width` x `height` (doubled from 40 x 30)
/// whose unguided frame takes at least `frame_s` here, and that frame's time.
fn sized(name: &str, guiding: bool, frame_s: f64) -> (PreparedScene, f64) {
    let s = scene(name);
    let (mut w, mut h) = (40u32, 30u32);
    loop {
        let mut o = options(&s, w, h, 64);
        if guiding {
            o.guiding = rlpt::guide::GuidingMode::Sphere;
        }
        let p = PreparedScene::new(&s, &o).expect("valid options");
        let start = Instant::now();
        CpuRenderer::new(&p).render_frame();
        let t = start.elapsed().as_secs_f64();
        if t >= frame_s || w >= 1280 {
            return (p, t);
        }
        (w, h) = if w > h { (w, h * 2) } else { (w * 2, h) };
    }
}

/// Renders `p` for `t_s` seconds by a session as `rlpt render --time` does; the
/// wall time, the frames traced and the image's samples per pixel.
fn timed(p: &PreparedScene, t_s: f64) -> (f64, u32, u64) {
    let renderer = CpuRenderer::new(p);
    let paths = (p.params.width * p.params.height * 64) as f64;
    let mut session = Session::new(Box::new(renderer), None, paths);
    let start = Instant::now();
    let budget = Budget { frames: 1_000_000, time_ms: Some(t_s * 1e3) };
    session.run(budget, &AtomicBool::new(false)).expect("the render runs");
    let wall = start.elapsed().as_secs_f64();
    let spp = session.renderer.film().unwrap().samples_per_pixel();
    assert_eq!(session.frames.last().map(|f| f.spp as u64), Some(spp), "the stats' last spp is the film's");
    (wall, session.traced(), spp)
}

/// Unguided and guided, at a size where a frame takes about half a second, a
/// render of 2.5 frames' time ends within `MARGIN_S` of it; stopping after the
/// last whole frame that fits, as before, it would end half a frame early.
#[test]
fn a_timed_cpu_render_ends_at_its_limit() {
    for (name, guiding) in [("cornell-box.toml", false), ("door.toml", true)] {
        let (p, frame) = sized(name, guiding, 0.4);
        let t = (2.5 * frame).max(1.0);
        let (wall, frames, spp) = timed(&p, t);
        let what = format!(
            "{name} guiding {guiding} at {}x{} (a frame {frame:.2} s): --time {t:.2} took {wall:.3} s, {frames} frames, {spp} spp",
            p.params.width, p.params.height
        );
        println!("{what}");
        assert!((wall - t).abs() <= MARGIN_S, "{what}");
    }
}
