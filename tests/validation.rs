//! The validation checks themselves can fail: the layer's messages are counted, a
//! synchronization hazard is one of them, and so is an object leaked until the
//! context's destruction (seen after the context is gone). Every GPU test relies on
//! this (`common::gpu`, the CLI tests' `checked_output`).

use rlpt::gpu::{vk, Buffer, BufferUsage, Context, ContextOptions};

fn context() -> std::sync::Arc<Context> {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    Context::new(&ContextOptions { gpu: None, validation: true, window: None }).expect("lavapipe and the layer")
}

/// Two copies into one buffer with no barrier between them: a write-after-write
/// hazard that only synchronization validation reports.
#[test]
fn a_missing_barrier_is_reported() {
    let ctx = context();
    let counter = ctx.validation_counter();
    let src = Buffer::new(&ctx, "hazard source", 256, BufferUsage::Storage).unwrap();
    let dst = Buffer::new(&ctx, "hazard destination", 256, BufferUsage::Storage).unwrap();
    ctx.run_commands("a clean copy", |cmd| src.cmd_copy_to(cmd, &dst)).unwrap();
    assert_eq!(counter.get(), 0, "one copy is no hazard");
    ctx.run_commands("two copies, no barrier", |cmd| {
        src.cmd_copy_to(cmd, &dst);
        src.cmd_copy_to(cmd, &dst);
    })
    .unwrap();
    assert!(counter.get() > 0, "synchronization validation is on and counted");
}

/// A buffer never destroyed is reported when the device is: after the context is
/// dropped, its counter still reads the message.
#[test]
fn a_leak_is_reported_at_teardown() {
    let ctx = context();
    let counter = ctx.validation_counter();
    let info = vk::BufferCreateInfo::default().size(64).usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: a valid create info on a live device; the buffer is leaked on purpose.
    let _leaked = unsafe { ctx.device.create_buffer(&info, None) }.unwrap();
    assert_eq!(counter.get(), 0);
    drop(ctx);
    assert!(counter.get() > 0, "the leak was reported while the context was destroyed");
}
