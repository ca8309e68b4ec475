//! Projector-camera simulator with per-pixel ground truth. Placeholder until written.
