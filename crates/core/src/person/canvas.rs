//! The labelled head frame that the person pass's hair readings share (`traits` measures
//! on it, `silhouette` draws the hair's outline from it). Units: IOD (the distance between
//! the eyes), as everywhere in the pass.

use super::Label;

/// The labelled head frame that the hair's readings measure: its `w` x `h` pixels' labels,
/// each pixel's head-frame point (`pos`, IOD), which pixels are the face's (not scalp), the
/// skull's normalised radius at a point (1 on its outline), the face's length (eyes to chin)
/// and half-width, IOD.
#[derive(Clone, Copy)]
pub(super) struct Canvas<'a> {
    pub labels: &'a [Label],
    pub w: usize,
    pub h: usize,
    pub pos: &'a dyn Fn(usize) -> [f32; 2],
    pub in_face: &'a [bool],
    pub skull: &'a dyn Fn([f32; 2]) -> f32,
    pub chin: f32,
    pub half: f32,
}
