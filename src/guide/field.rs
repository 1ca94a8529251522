//! Learned fields saved and loaded (`--guide-out`, `--guide-in`): a table learned
//! by one render serves another of the same scene (a preview's learning the final
//! render, an animation's frames, a split render's parts).
//!
//! The file: the magic `RLPTQTAB`, the format version, the hash of the scene's
//! geometry, materials and lights ([`scene_hash`]), the grid, the bins, the
//! table's cells and those in use, then Q, visits, the cells' fraction states,
//! the rows read and the cells' tree nodes, all little-endian.
//! The sampling rows are not stored: they are rebuilt from Q on load, as the
//! table's learning pass builds them.

use super::*;
use std::path::Path;

const MAGIC: &[u8; 8] = b"RLPTQTAB";
/// The format's version; a file of another is refused.
pub const FIELD_VERSION: u32 = 2;

/// A learned table with the shape it was learned in.
#[derive(Clone, Debug, PartialEq)]
pub struct GuideField {
    /// [`scene_hash`] of the scene it was learned on.
    pub scene_hash: u64,
    pub grid: Grid,
    pub bins: Bins,
    pub q: Vec<f32>,
    pub visits: Vec<u32>,
    pub fraction_states: Vec<FractionState>,
    pub rows_read: Vec<bool>,
    /// The adaptive grid's tree ([`QTable::nodes`], [`QTable::used_cells`]).
    pub nodes: Vec<CellNode>,
    pub used_cells: u32,
}

/// Why a field could not be saved, loaded or used: one sentence naming the file.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct FieldError(pub String);

/// FNV-1a over the bytes of what light transport in a scene depends on: its
/// geometry, materials and lights, as prepared for rendering (not the camera,
/// the image size or the render's options, which a learned field outlives).
pub fn scene_hash(scene: &SceneArrays) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in (bytes.len() as u64).to_le_bytes().iter().chain(bytes) {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    };
    eat(bytemuck::cast_slice(&scene.materials));
    eat(bytemuck::cast_slice(&scene.spheres));
    eat(bytemuck::cast_slice(&scene.quads));
    eat(bytemuck::cast_slice(&scene.triangles));
    eat(bytemuck::cast_slice(&scene.lights));
    // Only where there are any, so that the hashes of scenes without them stay as they were.
    if !scene.delta_lights.is_empty() {
        eat(bytemuck::cast_slice(&scene.delta_lights));
    }
    eat(bytemuck::bytes_of(&scene.params.environment));
    h
}

impl GuideField {
    /// The field of `table`, learned in `cfg` on the scene of hash `scene_hash`.
    pub fn of_table(table: &QTable, cfg: &GuideConfig, scene_hash: u64) -> GuideField {
        GuideField {
            scene_hash,
            grid: cfg.grid,
            bins: cfg.bins,
            q: table.q.clone(),
            visits: table.visits.clone(),
            fraction_states: table.fraction_states.clone(),
            rows_read: table.rows_read.clone(),
            nodes: table.nodes.clone(),
            used_cells: table.used_cells,
        }
    }

    /// The frames a loaded field counts as having learned from, for learned
    /// roulette, which waits for a table of [`shared::LEARNED_RR_FRAMES`] frames:
    /// a field is taken to be past that. `glsl/pathtrace.comp`'s `table_frames`.
    pub fn table_frames() -> u32 {
        shared::LEARNED_RR_FRAMES
    }

    /// The table this field holds for `cfg` (whose grid and bins must be the
    /// field's), its sampling rows and fractions rebuilt from Q.
    pub fn table(&self, cfg: &GuideConfig) -> QTable {
        let mut t = QTable::new(cfg);
        t.q.clone_from(&self.q);
        t.visits.clone_from(&self.visits);
        t.fraction_states.clone_from(&self.fraction_states);
        t.rows_read.clone_from(&self.rows_read);
        t.nodes.clone_from(&self.nodes);
        t.used_cells = self.used_cells;
        t.learn(cfg, &FrameSums::for_config(cfg));
        t
    }

    /// Writes the field to `path`.
    pub fn save(&self, path: &Path) -> Result<(), FieldError> {
        let mut out = Vec::with_capacity(64 + self.q.len() * 8 + self.fraction_states.len() * 16);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FIELD_VERSION.to_le_bytes());
        out.extend_from_slice(&self.scene_hash.to_le_bytes());
        for v in self.grid.min.to_array().into_iter().chain(self.grid.max.to_array()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let shape = [self.bins.rows, self.bins.cols, self.grid.capacity, self.used_cells];
        for v in self.grid.res.into_iter().chain(shape) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        self.q.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        self.visits.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        for s in &self.fraction_states {
            for v in [s.theta, s.m, s.v, s.steps] {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out.extend(self.rows_read.iter().map(|&r| r as u8));
        out.extend_from_slice(bytemuck::cast_slice(&self.nodes));
        std::fs::write(path, out)
            .map_err(|e| FieldError(format!("cannot write the learned field {}: {e}", path.display())))
    }

    /// Reads a field from `path`, refusing a file that is not one, of another
    /// version, or cut short.
    pub fn load(path: &Path) -> Result<GuideField, FieldError> {
        let name = path.display();
        let bytes =
            std::fs::read(path).map_err(|e| FieldError(format!("cannot read the learned field {name}: {e}")))?;
        let mut r = Reader { bytes: &bytes, at: 0 };
        let short = || FieldError(format!("{name} is cut short: it ends before the table its header describes"));
        if r.take(8).ok_or_else(short)? != MAGIC {
            return Err(FieldError(format!("{name} is not an rlpt learned field (it does not start with RLPTQTAB)")));
        }
        let version = r.u32().ok_or_else(short)?;
        if version != FIELD_VERSION {
            return Err(FieldError(format!(
                "{name} is a learned field of format version {version}; this rlpt reads version {FIELD_VERSION}"
            )));
        }
        let scene_hash = r.u64().ok_or_else(short)?;
        let mut f = [0f32; 6];
        for v in &mut f {
            *v = r.f32().ok_or_else(short)?;
        }
        let mut u = [0u32; 7];
        for v in &mut u {
            *v = r.u32().ok_or_else(short)?;
        }
        let (min, max) = (Vec3::new(f[0], f[1], f[2]), Vec3::new(f[3], f[4], f[5]));
        let grid = Grid { min, max, res: [u[0], u[1], u[2]], capacity: u[5] };
        let bins = Bins { rows: u[3], cols: u[4] };
        let used_cells = u[6];
        let roots = grid.res.iter().try_fold(1u64, |a, &n| a.checked_mul(n as u64));
        let bad_shape = !(f.iter().all(|v| v.is_finite()) && grid.min.cmplt(grid.max).all())
            || grid.res.contains(&0)
            || bins.rows == 0
            || bins.cols == 0
            || bins.rows as u64 * bins.cols as u64 > Bins::MAX_COUNT
            || roots.is_none_or(|n| n > grid.capacity as u64 || n > used_cells as u64)
            || used_cells > grid.capacity;
        let cells = grid.capacity as u64;
        let fits = cells.checked_mul(bins.rows as u64 * bins.cols as u64 * 8).is_some_and(|n| n <= bytes.len() as u64);
        if bad_shape || !fits {
            return Err(FieldError(format!(
                "{name}: its header's table shape (grid {:?} over {} to {}, {}x{} bins, {} cells of which {used_cells} \
                 in use) is not one rlpt writes, or larger than the file",
                grid.res, grid.min, grid.max, bins.rows, bins.cols, grid.capacity
            )));
        }
        let (cells, entries) = (cells as usize, cells as usize * bins.count() as usize);
        let q = (0..entries).map(|_| r.f32()).collect::<Option<Vec<f32>>>().ok_or_else(short)?;
        let visits = (0..entries).map(|_| r.u32()).collect::<Option<Vec<u32>>>().ok_or_else(short)?;
        let fraction_states = (0..cells)
            .map(|_| Some(FractionState { theta: r.f32()?, m: r.f32()?, v: r.f32()?, steps: r.f32()? }))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(short)?;
        let rows_read = r.take(cells * NORMAL_CLASSES as usize).ok_or_else(short)?.iter().map(|&b| b != 0).collect();
        let node_bytes = r.take(cells * std::mem::size_of::<CellNode>()).ok_or_else(short)?;
        let nodes: Vec<CellNode> = bytemuck::pod_collect_to_vec(node_bytes);
        if r.at != bytes.len() {
            return Err(FieldError(format!(
                "{name} has {} bytes after the table its header describes",
                bytes.len() - r.at
            )));
        }
        if let Some(i) = q.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(FieldError(format!("{name}: Q entry {i} is {}, not a finite radiance", q[i])));
        }
        // A child outside the cells in use would send the lookup out of the table.
        let roots = grid.cells();
        let bad_node = nodes.iter().position(|n| {
            n.depth > shared::GUIDE_TREE_DEPTH
                || (n.first_child != 0 && (n.first_child < roots || n.first_child as u64 + 8 > used_cells as u64))
        });
        if let Some(i) = bad_node {
            return Err(FieldError(format!(
                "{name}: cell {i}'s tree node ({:?}) points outside the {used_cells} cells in use",
                nodes[i]
            )));
        }
        Ok(GuideField { scene_hash, grid, bins, q, visits, fraction_states, rows_read, nodes, used_cells })
    }

    /// Refuses the field where it was learned on another scene than the one of
    /// hash `scene_hash`, or in other bins than `bins`, with a sentence naming
    /// `path` and what differs.
    pub fn check(&self, path: &Path, scene_hash: u64, bins: Bins) -> Result<(), FieldError> {
        let name = path.display();
        if self.scene_hash != scene_hash {
            return Err(FieldError(format!(
                "{name} was learned on another scene (its scene hash {:016x}, this scene's {scene_hash:016x}): \
                 geometry, materials or lights differ",
                self.scene_hash
            )));
        }
        if self.bins != bins {
            return Err(FieldError(format!(
                "{name} was learned with {}x{} bins and this render asks for {}x{}: pass --guiding sphere --bins {}x{}",
                self.bins.rows, self.bins.cols, bins.rows, bins.cols, self.bins.rows, self.bins.cols
            )));
        }
        Ok(())
    }
}

/// Little-endian fields read in order from a byte slice.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f32(&mut self) -> Option<f32> {
        Some(f32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
}
