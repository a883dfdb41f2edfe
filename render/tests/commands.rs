//! The command log (`render::gpu::commands`) on the test device: logged commands replay to
//! what they say (a fill, copies, an inline update and barriers leave the bytes they should), a
//! frame that logs the same commands submits its buffer again without recording, and a
//! destroyed object, or different arguments, make the next frame record.

use ash::vk;
use gpu_allocator::MemoryLocation;
use render::gpu::commands::{CommandCache, Recorder, Recording};
use render::gpu::device::{DeviceSettings, GpuContext};
use render::gpu::memory::Buffer;

const UPDATE: [u8; 12] = *b"logged bytes";

struct Buffers {
    a: Buffer,
    b: Buffer,
    host: Buffer,
}

/// Logs a frame: fill `a` with `value`, copy it into `b` at 16, write [`UPDATE`] into `b` at
/// 128, copy `b` to the host buffer; then finishes, submits and waits.
fn frame(ctx: &GpuContext, cache: CommandCache, bufs: &Buffers, value: u32) -> (CommandCache, Recording) {
    let rec = Recorder::new(ctx, cache, true);
    let transfer = |src: vk::PipelineStageFlags2, dst: vk::PipelineStageFlags2, dst_access: vk::AccessFlags2| {
        [vk::MemoryBarrier2::default()
            .src_stage_mask(src)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(dst)
            .dst_access_mask(dst_access)]
    };
    // Fills and updates count as transfers (copies, for synchronization validation).
    let (copy, all) = (vk::PipelineStageFlags2::COPY, vk::PipelineStageFlags2::ALL_TRANSFER);
    rec.fill_buffer(bufs.a.raw, 0, 64, value);
    rec.barrier(&transfer(all, copy, vk::AccessFlags2::TRANSFER_READ), &[]);
    rec.copy_buffer(bufs.a.raw, bufs.b.raw, &[vk::BufferCopy { src_offset: 0, dst_offset: 16, size: 64 }]);
    rec.update_buffer(bufs.b.raw, 128, &UPDATE);
    rec.barrier(&transfer(all, copy, vk::AccessFlags2::TRANSFER_READ), &[]);
    rec.copy_buffer(bufs.b.raw, bufs.host.raw, &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size: 256 }]);
    rec.barrier(&transfer(copy, vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ), &[]);
    let (cache, how) = rec.finish();
    let how = how.expect("finish the frame");
    let d = &ctx.device;
    // SAFETY: the buffer is recorded and ended; the fence wait finishes it before the fence is
    // destroyed and before the next frame records or submits it again.
    unsafe {
        let fence = d.create_fence(&vk::FenceCreateInfo::default(), None).expect("fence");
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cache.cmd())];
        d.queue_submit2(ctx.queue, &[vk::SubmitInfo2::default().command_buffer_infos(&cmds)], fence).expect("submit");
        d.wait_for_fences(&[fence], true, u64::MAX).expect("wait");
        d.destroy_fence(fence, None);
    }
    (cache, how)
}

/// Clears the host copy, runs a frame and checks what it copied back.
fn frame_checked(ctx: &GpuContext, cache: CommandCache, bufs: &mut Buffers, value: u32) -> (CommandCache, Recording) {
    bufs.host.mapped()[..256].fill(0xee);
    let (cache, how) = frame(ctx, cache, bufs, value);
    let host = &bufs.host.mapped()[..256];
    let words: Vec<u32> = host[16..80].chunks(4).map(|c| u32::from_ne_bytes(c.try_into().unwrap())).collect();
    assert_eq!(words, vec![value; 16], "the fill, copied into b and back");
    assert_eq!(host[128..140], UPDATE, "the inline update");
    (cache, how)
}

#[test]
fn logged_commands_replay_and_a_repeated_log_is_submitted_again() {
    let ctx = GpuContext::new(&DeviceSettings { validation: true, ..Default::default() }).expect("device");
    let usage = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    let new = |name, location| Buffer::new(&ctx, name, 256, usage, location).expect("buffer");
    let mut bufs =
        Buffers { a: new("a", MemoryLocation::GpuOnly), b: new("b", MemoryLocation::GpuOnly), host: new("host", MemoryLocation::GpuToCpu) };
    let cache = CommandCache::new(&ctx).expect("command cache");

    let (cache, first) = frame_checked(&ctx, cache, &mut bufs, 7);
    assert_eq!(first, Recording::Recorded);
    let (cache, again) = frame_checked(&ctx, cache, &mut bufs, 7);
    assert_eq!(again, Recording::Reused, "the same commands: submitted again, and they ran");
    let (cache, other) = frame_checked(&ctx, cache, &mut bufs, 8);
    assert_eq!(other, Recording::Recorded, "another fill value: recorded");
    let (cache, again) = frame_checked(&ctx, cache, &mut bufs, 8);
    assert_eq!(again, Recording::Reused);

    // An object destroyed since: its handle might now name a new object, so no reuse.
    new("gone", MemoryLocation::GpuOnly).destroy(&ctx);
    let (cache, after) = frame_checked(&ctx, cache, &mut bufs, 8);
    assert_eq!(after, Recording::Recorded, "an object was destroyed: recorded");

    // A command the log lacks makes the frame direct, never reused.
    let rec = Recorder::new(&ctx, cache, true);
    rec.direct().expect("direct");
    let (cache, how) = rec.finish();
    assert_eq!(how.expect("finish"), Recording::Direct);

    cache.destroy(&ctx);
    for b in [bufs.a, bufs.b, bufs.host] {
        b.destroy(&ctx);
    }
    let errors = ctx.validation.take_errors();
    assert!(errors.is_empty(), "validation errors: {errors:?}");
}
