use super::buffer::Buffer;
use super::context::{Context, GpuError, Result};
use ash::vk;
use std::sync::Arc;

/// The kind of a descriptor binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binding {
    Uniform,
    Storage,
}

/// One statistic the driver reports about a compiled pipeline.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PipelineStatistic {
    /// The executable (shader stage) it describes.
    pub executable: String,
    /// The subgroup size the executable was compiled for.
    pub subgroup_size: u32,
    pub name: String,
    pub value: String,
    pub description: String,
}

/// A compute pipeline with one descriptor set (set 0, bindings 0..n in the
/// order given) and an optional push-constant block. The compiled pipeline and
/// its layouts are shared with the other `Pipeline`s of the same shader,
/// bindings, push-constant size and specialization on the context
/// (`PipelineCache`); the descriptor set is its own.
pub struct Pipeline {
    ctx: Arc<Context>,
    pub name: String,
    compiled: Arc<Compiled>,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
    bindings: Vec<(u32, Binding)>,
    push_size: u32,
}

/// A compiled pipeline with its set and pipeline layouts; destroyed when the
/// last [`Pipeline`] using it and the context's cache have let it go.
struct Compiled {
    device: ash::Device,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    raw: vk::Pipeline,
}

impl Drop for Compiled {
    fn drop(&mut self) {
        // SAFETY: no Pipeline uses it any more, and the GPU has finished with
        // those that did (work is waited for before drops); the device is alive
        // (the context clears its cache before destroying it).
        unsafe {
            self.device.destroy_pipeline(self.raw, None);
            self.device.destroy_pipeline_layout(self.layout, None);
            self.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// What makes two pipelines the same: the shader (its compiled SPIR-V, a
/// static of the binary, by address), bindings, push-constant size and
/// specialization constants.
#[derive(PartialEq, Eq)]
struct PipelineKey {
    spirv: (usize, usize),
    bindings: Vec<(u32, Binding)>,
    push_size: u32,
    constants: Vec<u32>,
}

/// How many compiled pipelines a context keeps, the most recently used: a
/// restart of the viewer or another render in the same process with options
/// seen before compiles nothing (creating the path-tracing kernel is slow,
/// most of all on a CPU device).
pub const PIPELINE_CACHE_SIZE: usize = 32;

/// A context's compiled pipelines, the most recently used last, and how many
/// it has compiled.
#[derive(Default)]
pub(super) struct PipelineCache {
    entries: std::sync::Mutex<Vec<(PipelineKey, Arc<Compiled>)>>,
    pub(super) compiled: std::sync::atomic::AtomicU64,
}

impl PipelineCache {
    fn entries(&self) -> std::sync::MutexGuard<'_, Vec<(PipelineKey, Arc<Compiled>)>> {
        self.entries.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn get(&self, key: &PipelineKey) -> Option<Arc<Compiled>> {
        let mut entries = self.entries();
        let i = entries.iter().position(|(k, _)| k == key)?;
        let entry = entries.remove(i);
        let compiled = entry.1.clone();
        entries.push(entry);
        Some(compiled)
    }

    /// Keeps a pipeline just compiled, counted in `compiled`, pushing out the
    /// least recently used past [`PIPELINE_CACHE_SIZE`].
    fn insert(&self, key: PipelineKey, compiled: Compiled) -> Arc<Compiled> {
        self.compiled.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let compiled = Arc::new(compiled);
        let mut entries = self.entries();
        entries.push((key, compiled.clone()));
        if entries.len() > PIPELINE_CACHE_SIZE {
            entries.remove(0);
        }
        compiled
    }

    /// Lets every pipeline go: the context's drop, before the device's.
    pub(super) fn clear(&self) {
        self.entries().clear();
    }
}

impl Pipeline {
    /// Bindings numbered 0..n in the order given.
    pub fn new(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &'static [u8],
        bindings: &[Binding],
        push_size: u32,
    ) -> Result<Pipeline> {
        let numbered: Vec<(u32, Binding)> = bindings.iter().enumerate().map(|(i, b)| (i as u32, *b)).collect();
        Pipeline::new_with_numbers(ctx, name, spirv, &numbered, push_size)
    }

    /// Bindings with explicit numbers, as the shader declares them.
    pub fn new_with_numbers(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &'static [u8],
        bindings: &[(u32, Binding)],
        push_size: u32,
    ) -> Result<Pipeline> {
        Pipeline::new_specialized(ctx, name, spirv, bindings, push_size, &[])
    }

    /// Bindings with explicit numbers, and `constants[i]` as the value of the
    /// shader's 32-bit specialization constant `constant_id = i`. Compiles the
    /// pipeline unless the context holds one of the same key (`PipelineCache`).
    pub fn new_specialized(
        ctx: &Arc<Context>,
        name: &str,
        spirv: &'static [u8],
        bindings: &[(u32, Binding)],
        push_size: u32,
        constants: &[u32],
    ) -> Result<Pipeline> {
        let key = PipelineKey {
            spirv: (spirv.as_ptr() as usize, spirv.len()),
            bindings: bindings.to_vec(),
            push_size,
            constants: constants.to_vec(),
        };
        let compiled = match ctx.pipelines.get(&key) {
            Some(c) => c,
            None => ctx.pipelines.insert(key, compile(ctx, name, spirv, bindings, push_size, constants)?),
        };
        let dev = &ctx.device;
        let mut sizes = Vec::new();
        for kind in [Binding::Uniform, Binding::Storage] {
            let n = bindings.iter().filter(|(_, b)| *b == kind).count() as u32;
            if n > 0 {
                sizes.push(vk::DescriptorPoolSize { ty: descriptor_type(kind), descriptor_count: n });
            }
        }
        let set_layouts = [compiled.set_layout];
        // SAFETY (this block): plain object creation on a live device; the pool is
        // destroyed in Drop, or below if the set's allocation fails.
        unsafe {
            let pool = dev
                .create_descriptor_pool(&vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes), None)
                .map_err(|e| GpuError::vk("vkCreateDescriptorPool", e))?;
            let set = match dev.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&set_layouts),
            ) {
                Ok(s) => s[0],
                Err(e) => {
                    dev.destroy_descriptor_pool(pool, None);
                    return Err(GpuError::vk("vkAllocateDescriptorSets", e));
                }
            };
            ctx.set_name(set, &format!("{name} descriptors"));
            Ok(Pipeline {
                ctx: ctx.clone(),
                name: name.to_string(),
                compiled,
                pool,
                set,
                bindings: bindings.to_vec(),
                push_size,
            })
        }
    }

    /// The compiled pipeline, shared with the other `Pipeline`s of its key.
    pub fn raw(&self) -> vk::Pipeline {
        self.compiled.raw
    }

    /// Points every binding at its buffer (`buffers[i]` for the i-th binding given at
    /// creation). Call while the set is not in use.
    pub fn bind(&self, buffers: &[&Buffer]) {
        assert_eq!(buffers.len(), self.bindings.len(), "{}: one buffer per binding", self.name);
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|b| [vk::DescriptorBufferInfo { buffer: b.raw, offset: 0, range: vk::WHOLE_SIZE }])
            .collect();
        let writes: Vec<_> = self
            .bindings
            .iter()
            .zip(&infos)
            .map(|((i, kind), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(*i)
                    .descriptor_type(descriptor_type(*kind))
                    .buffer_info(info)
            })
            .collect();
        // SAFETY: the set and buffers are alive; the caller ensures the set is not in use by the GPU.
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// What the driver says the compiled pipeline uses (registers, shared memory,
    /// instructions...), as (name, value, description) per statistic; empty where the
    /// device lacks `VK_KHR_pipeline_executable_properties`.
    pub fn statistics(&self) -> Result<Vec<PipelineStatistic>> {
        if !self.ctx.info.pipeline_statistics {
            return Ok(Vec::new());
        }
        let ext = ash::khr::pipeline_executable_properties::Device::new(&self.ctx.instance, &self.ctx.device);
        let text = |c: std::result::Result<&std::ffi::CStr, std::ffi::FromBytesUntilNulError>| {
            c.map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
        };
        let mut out = Vec::new();
        // SAFETY: the pipeline was created with CAPTURE_STATISTICS on a device with the extension enabled.
        let executables = unsafe {
            ext.get_pipeline_executable_properties(&vk::PipelineInfoKHR::default().pipeline(self.compiled.raw))
        }
        .map_err(|e| GpuError::vk("vkGetPipelineExecutablePropertiesKHR", e))?;
        for (index, exe) in executables.iter().enumerate() {
            let info =
                vk::PipelineExecutableInfoKHR::default().pipeline(self.compiled.raw).executable_index(index as u32);
            // SAFETY: as above; `index` is below the count just returned.
            let stats = unsafe { ext.get_pipeline_executable_statistics(&info) }
                .map_err(|e| GpuError::vk("vkGetPipelineExecutableStatisticsKHR", e))?;
            for s in stats {
                // SAFETY: the union member read is the one `format` names.
                let value = unsafe {
                    match s.format {
                        vk::PipelineExecutableStatisticFormatKHR::BOOL32 => (s.value.b32 == vk::TRUE).to_string(),
                        vk::PipelineExecutableStatisticFormatKHR::INT64 => s.value.i64.to_string(),
                        vk::PipelineExecutableStatisticFormatKHR::UINT64 => s.value.u64.to_string(),
                        vk::PipelineExecutableStatisticFormatKHR::FLOAT64 => format!("{:.3}", s.value.f64),
                        _ => "?".into(),
                    }
                };
                out.push(PipelineStatistic {
                    executable: text(exe.name_as_c_str()),
                    subgroup_size: exe.subgroup_size,
                    name: text(s.name_as_c_str()),
                    value,
                    description: text(s.description_as_c_str()),
                });
            }
        }
        Ok(out)
    }

    /// Records a dispatch of `groups` workgroups with `push` as push constants.
    pub fn cmd_dispatch(&self, cmd: vk::CommandBuffer, groups: [u32; 3], push: &[u8]) {
        assert_eq!(push.len() as u32, self.push_size, "{}: push-constant size", self.name);
        let dev = &self.ctx.device;
        // SAFETY: `cmd` is recording; the pipeline, layout and set are alive and the set is bound to live buffers.
        unsafe {
            dev.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.compiled.raw);
            dev.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.compiled.layout,
                0,
                &[self.set],
                &[],
            );
            if !push.is_empty() {
                dev.cmd_push_constants(cmd, self.compiled.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            }
            dev.cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
        }
    }
}

fn descriptor_type(b: Binding) -> vk::DescriptorType {
    match b {
        Binding::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
        Binding::Storage => vk::DescriptorType::STORAGE_BUFFER,
    }
}

/// Compiles a pipeline of set 0 with `bindings`, a push-constant block of
/// `push_size` bytes and the specialization `constants`, named `name`.
fn compile(
    ctx: &Arc<Context>,
    name: &str,
    spirv: &[u8],
    bindings: &[(u32, Binding)],
    push_size: u32,
    constants: &[u32],
) -> Result<Compiled> {
    let code = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).expect("build.rs wrote valid SPIR-V");
    let dev = &ctx.device;
    let layout_bindings: Vec<_> = bindings
        .iter()
        .map(|(i, b)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(*i)
                .descriptor_type(descriptor_type(*b))
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        })
        .collect();
    // SAFETY (this block): plain object creation on a live device; every object made
    // here is destroyed by Compiled's drop, or below if a later step fails.
    unsafe {
        let set_layout = dev
            .create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings),
                None,
            )
            .map_err(|e| GpuError::vk("vkCreateDescriptorSetLayout", e))?;
        let set_layouts = [set_layout];
        let ranges = [vk::PushConstantRange { stage_flags: vk::ShaderStageFlags::COMPUTE, offset: 0, size: push_size }];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_size > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        let layout = match dev.create_pipeline_layout(&layout_info, None) {
            Ok(l) => l,
            Err(e) => {
                dev.destroy_descriptor_set_layout(set_layout, None);
                return Err(GpuError::vk("vkCreatePipelineLayout", e));
            }
        };
        let module = match dev.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None) {
            Ok(m) => m,
            Err(e) => {
                dev.destroy_pipeline_layout(layout, None);
                dev.destroy_descriptor_set_layout(set_layout, None);
                return Err(GpuError::vk("vkCreateShaderModule", e));
            }
        };
        let entries: Vec<vk::SpecializationMapEntry> = (0..constants.len() as u32)
            .map(|i| vk::SpecializationMapEntry { constant_id: i, offset: 4 * i, size: 4 })
            .collect();
        let spec = vk::SpecializationInfo::default().map_entries(&entries).data(bytemuck::cast_slice(constants));
        let mut stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        if !constants.is_empty() {
            stage = stage.specialization_info(&spec);
        }
        let flags = if ctx.info.pipeline_statistics {
            vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR
        } else {
            vk::PipelineCreateFlags::empty()
        };
        let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout).flags(flags)];
        let pipeline = dev.create_compute_pipelines(vk::PipelineCache::null(), &info, None);
        dev.destroy_shader_module(module, None);
        let raw = match pipeline {
            Ok(p) => p[0],
            Err((_, e)) => {
                dev.destroy_pipeline_layout(layout, None);
                dev.destroy_descriptor_set_layout(set_layout, None);
                return Err(GpuError::vk("vkCreateComputePipelines", e));
            }
        };
        ctx.set_name(raw, name);
        ctx.set_name(layout, &format!("{name} layout"));
        Ok(Compiled { device: dev.clone(), set_layout, layout, raw })
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        let dev = &self.ctx.device;
        // SAFETY: the GPU has finished with the pipeline (work is waited for before drops).
        unsafe {
            dev.destroy_descriptor_pool(self.pool, None);
        }
    }
}
