//! Inside or outside a triangle mesh, decided the one way the whole crate decides it: by the
//! voxelizer for its densities ([`crate::voxelize`], paper 4.1) and by the exact distance for
//! its sign ([`crate::mesh_query`]).
//!
//! The mesh is first re-oriented consistently ([`orient`]). Grids of parallel rays along the
//! three axes ([`rays`]) each vote at a point: a ray whose crossings balance by the nonzero
//! winding rule, otherwise by parity when its crossings are even; a ray with an odd number of
//! crossings passed through a hole and abstains. When at least two rays vote and all agree
//! ([`Votes::verdict`]) that is the answer; otherwise the generalized winding number of the
//! re-oriented mesh ([`winding`]) decides, inside where it exceeds one half.

pub(crate) mod orient;
pub(crate) mod rays;
pub(crate) mod winding;

/// The votes of the rays at one point.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Votes {
    inside: u8,
    outside: u8,
}

impl Votes {
    pub(crate) fn add(&mut self, vote: Option<bool>) {
        match vote {
            Some(true) => self.inside += 1,
            Some(false) => self.outside += 1,
            None => {}
        }
    }

    /// The verdict when at least two rays vote and all agree.
    pub(crate) fn verdict(self) -> Option<bool> {
        match (self.inside, self.outside) {
            (n, 0) if n >= 2 => Some(true),
            (0, n) if n >= 2 => Some(false),
            _ => None,
        }
    }
}
