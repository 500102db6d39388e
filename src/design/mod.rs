//! Designing the sequence library for the person: how long each entry
//! takes this user to breathe and how often a misread breath lands in
//! another entry ([`analysis`]), and the library that minimises both for
//! their usage ([`search`]).
//!
//! One sample's path: a [`Breathing`](breathing::Breathing) says how the
//! person breathes and, with their gesture set ([`gesturing`]), makes
//! their gestures; sequences are of [`symbol`]s, bursts and gestures;
//! [`reading`] lists what the detector and the recognizer may read
//! instead of a meant sequence and what the matcher then does;
//! [`analysis`] sums it per entry, weighted by the [`usage`] mix;
//! [`search`] places the entries on sequences to minimise that sum.
//!
//! The whole job ([`designing`]): a [`request`] names the person, the
//! library and its usage ([`inputs`]); the search's [`problem`] is made
//! from it; the designed library is analysed again, tried in the study
//! ([`study_check`]), judged in one bottom line ([`verdict`]), written
//! ([`library_file`]), drawn ([`plot`]) and worded ([`report`]).

pub mod analysis;
pub mod breathing;
pub mod designing;
pub mod gesturing;
pub mod inputs;
pub mod library_file;
pub mod plot;
pub mod problem;
pub mod reading;
pub mod report;
pub mod request;
pub mod search;
pub mod study_check;
pub mod symbol;
pub mod usage;
pub mod verdict;
