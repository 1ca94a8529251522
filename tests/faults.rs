//! The device's faults as the library reports them. One test in this binary: it
//! sets a test hook in the process's environment, which every context made in the
//! process would read.

use rlpt::gpu::{Buffer, BufferUsage, Context, ContextOptions, GpuError, DEVICE_MEMORY_HOOK};

#[test]
fn an_allocation_past_the_device_memory_is_out_of_memory_and_freed_memory_returns() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    // The only test of this binary: no other thread reads the environment.
    std::env::set_var(DEVICE_MEMORY_HOOK, "8");
    let ctx = Context::new(&ContextOptions { gpu: None, validation: true, window: None }).unwrap();
    assert_eq!(ctx.info.device_memory, 8 << 20);
    let a = Buffer::new(&ctx, "first half", 4 << 20, BufferUsage::Storage).unwrap();
    let e = Buffer::new(&ctx, "accumulation", 5 << 20, BufferUsage::Storage).err().expect("past 8 MiB");
    assert!(matches!(e, GpuError::OutOfMemory { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        "the GPU ran out of memory allocating the accumulation buffer (5 MB) (other programs may hold some of it): \
         render a smaller image (--width, --height), with fewer guiding bins (--bins) or cells, or on the CPU \
         (--device cpu)"
    );
    drop(a);
    let b = Buffer::new(&ctx, "accumulation", 5 << 20, BufferUsage::Storage).expect("fits once the first is freed");
    drop(b);
    assert_eq!(ctx.validation_messages(), 0);
}
