//! The adaptive grid: the voxel grid's cells split into 8 where paths record many
//! targets, while the table has cells to spare ([`Grid::capacity`]). The lookup
//! [`cell_in_tree`] is `glsl/guide.glsl` `cell_index`; the split pass
//! [`QTable::refine`] is `glsl/learn.comp` `refine`. docs/guiding.md, "Adaptive cells".

use super::*;

/// A cell of the table (`glsl/common.glsl`, `BINDING_GUIDE_TREE`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CellNode {
    /// Its first child, 0 for a leaf: the 8 children are in a row, octant
    /// x + 2y + 4z (1 on an axis for the upper half).
    pub first_child: u32,
    /// 0 for the grid's own cells.
    pub depth: u32,
    /// The targets its entries had taken when its rows were last rebuilt.
    pub targets: f32,
    pub unused: u32,
}

/// Targets a leaf's entries must have taken to split: each child starts with an
/// eighth of them, enough for half its fraction ([`evidence_weight`]).
pub fn split_targets(bins: u32) -> f32 {
    (shared::SPLIT_TARGETS_PER_BIN * bins) as f32
}

/// The cell holding `p`: the grid's cell, then down the tree by octant, the point
/// taken in the cell's unit cube. `nodes` empty: the grid's cell.
/// `glsl/guide.glsl` `cell_index`.
pub fn cell_in_tree(grid: &Grid, nodes: &[CellNode], p: Vec3) -> u32 {
    let g = (p - grid.min) * grid.inv_cell_size();
    let clampi = |v: f32, n: u32| (v.max(0.0) as u32).min(n - 1);
    let (x, y, z) = (clampi(g.x, grid.res[0]), clampi(g.y, grid.res[1]), clampi(g.z, grid.res[2]));
    let mut cell = (z * grid.res[1] + y) * grid.res[0] + x;
    if nodes.is_empty() {
        return cell;
    }
    let mut f = (g - Vec3::new(x as f32, y as f32, z as f32)).clamp(Vec3::ZERO, Vec3::ONE);
    for _ in 0..shared::GUIDE_TREE_DEPTH {
        let first = nodes[cell as usize].first_child;
        if first == 0 {
            break;
        }
        let o = [f.x >= 0.5, f.y >= 0.5, f.z >= 0.5].map(|b| b as u32);
        cell = first + o[0] + 2 * o[1] + 4 * o[2];
        f = f * 2.0 - Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
    }
    cell
}

impl QTable {
    /// Splits the leaves whose targets reached [`split_targets`] and whose depth is
    /// below GUIDE_TREE_DEPTH, in cell order, while 8 more cells fit the table:
    /// each child starts from its parent's Q, an eighth of its visits and targets,
    /// its fraction's state and its rows read (so that the rows' rebuild builds
    /// the children's rows); the parent's rows are no longer read. Cells made in
    /// this pass split in a later one. Between the fold and the rows' rebuild of
    /// [`QTable::learn`]; `glsl/learn.comp` `refine`, in the same order.
    pub fn refine(&mut self, cfg: &GuideConfig) {
        if !cfg.grid.adaptive() {
            return;
        }
        let capacity = cfg.grid.capacity;
        let threshold = split_targets(cfg.bins.count());
        let end = self.used_cells;
        for cell in 0..end {
            let node = self.nodes[cell as usize];
            let splits = node.first_child == 0 && node.depth < shared::GUIDE_TREE_DEPTH && node.targets >= threshold;
            if !splits {
                continue;
            }
            if self.used_cells + 8 > capacity {
                break;
            }
            let first = self.used_cells;
            self.used_cells += 8;
            self.split_cell(cfg, cell, first);
        }
    }

    /// `learn.comp` `split_cell`.
    fn split_cell(&mut self, cfg: &GuideConfig, cell: u32, first: u32) {
        let n = cfg.bins.count() as usize;
        let classes = NORMAL_CLASSES as usize;
        let (cell, first) = (cell as usize, first as usize);
        let parent = self.nodes[cell];
        self.nodes[cell].first_child = first as u32;
        for child in first..first + 8 {
            self.nodes[child] =
                CellNode { first_child: 0, depth: parent.depth + 1, targets: parent.targets * 0.125, unused: 0 };
            for b in 0..n {
                self.q[child * n + b] = self.q[cell * n + b];
                self.visits[child * n + b] = self.visits[cell * n + b] / 8;
            }
            self.fraction_states[child] = self.fraction_states[cell];
            for c in 0..classes {
                self.rows_read[child * classes + c] = self.rows_read[cell * classes + c];
            }
        }
        for c in 0..classes {
            self.rows_read[cell * classes + c] = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(res: [u32; 3], capacity: u32) -> Grid {
        Grid { min: Vec3::ZERO, max: Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32), res, capacity }
    }

    /// Without splits a point's cell is the grid's; split, the point goes to the
    /// child of its octant (x + 2y + 4z), and on down a split child.
    #[test]
    fn a_point_goes_down_the_tree_by_octant() {
        let g = grid([2, 1, 1], 2 + 16);
        let mut nodes = vec![CellNode::default(); 18];
        let p = Vec3::new(1.7, 0.2, 0.9);
        assert_eq!(cell_in_tree(&g, &nodes, p), 1);
        assert_eq!(cell_in_tree(&g, &[], p), g.cell(p));
        nodes[1].first_child = 2;
        // In cell 1's unit cube (0.7, 0.2, 0.9): upper x, lower y, upper z.
        assert_eq!(cell_in_tree(&g, &nodes, p), 2 + 1 + 4);
        nodes[7].first_child = 10;
        // In that child's cube (0.4, 0.4, 0.8): lower x and y, upper z.
        assert_eq!(cell_in_tree(&g, &nodes, p), 10 + 4);
        // Outside the box: the nearest cell's nearest corner.
        assert_eq!(cell_in_tree(&g, &nodes, Vec3::new(9.0, -3.0, 9.0)), 10 + 1 + 4);
    }

    /// A leaf splits once its targets reach the threshold, in cell order, while 8
    /// cells fit; a cell made in the pass waits for the next; the deepest do not.
    #[test]
    fn leaves_that_learned_enough_split_while_the_table_has_room() {
        let bins = Bins { rows: 2, cols: 4 };
        let cfg = GuideConfig {
            mode: GuidingMode::Sphere,
            bins,
            grid: grid([2, 2, 1], 4 + 16),
            fraction: 0.5,
            learn_fraction: true,
            floor: DEFAULT_FLOOR,
            rate_exponent: 1.0,
            learning_frames: 0,
            unguided_frames: false,
            learning_period: None,
            adaptive_directions: false,
        };
        let mut t = QTable::new(&cfg);
        assert_eq!(t.used_cells, 4);
        let enough = split_targets(bins.count());
        for (cell, targets) in [(0, enough), (1, enough - 1.0), (2, enough), (3, enough)] {
            t.nodes[cell].targets = targets;
        }
        for b in 0..8 {
            t.q[2 * 8 + b] = b as f32;
            t.visits[2 * 8 + b] = 17 + b as u32;
        }
        t.rows_read[2 * 6 + 3] = true;
        t.refine(&cfg);
        // Cells 0 and 2 split; 3 finds no room.
        assert_eq!(t.used_cells, 20);
        assert_eq!([0, 1, 2, 3].map(|c| t.nodes[c].first_child), [4, 0, 12, 0]);
        for child in 12..20 {
            assert_eq!(t.nodes[child], CellNode { first_child: 0, depth: 1, targets: enough / 8.0, unused: 0 });
            assert_eq!(&t.q[child * 8..child * 8 + 8], &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
            assert_eq!(t.visits[child * 8], 17 / 8);
            assert!(t.rows_read[child * 6 + 3] && !t.rows_read[child * 6 + 2]);
        }
        assert!(!t.rows_read[2 * 6 + 3], "a split cell's rows are no longer read");
        // A child at the deepest level does not split.
        t.nodes[12].targets = 2.0 * enough;
        t.nodes[12].depth = shared::GUIDE_TREE_DEPTH;
        t.refine(&cfg);
        assert_eq!(t.nodes[12].first_child, 0);
    }
}
