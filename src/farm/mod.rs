//! A frame farmed out in parts: which pixels a part holds (`region`), the part file that
//! carries them with what they were rendered from (`part`), and the merge that checks
//! the parts and puts them together into the frame's bits (`merge`).

pub mod merge;
pub mod part;
pub(crate) mod region;
