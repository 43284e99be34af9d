//! Traced references kept between runs, content-addressed: a set of references is traced
//! once for a scene's content, its queries, seeds and sample counts, and read back by every
//! later run that asks for the same. They live in the bake folder's `references/` (a reused
//! bake brings them along; a new bake starts without them), one file per set, named by the
//! hash of everything the set depends on. A file is read only when its header names the
//! same key and length and its checksum holds; otherwise the set is traced again and the
//! file replaced. The values are stored as their bits, so a reused set is bit for bit the
//! traced one and every answer of the run is the same either way.

use crate::files::{FileError, Fnv};
use crate::trace::truth::TracedQueries;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

const MAGIC: &[u8] = b"warpfit-references\n";

/// Where a run's traced references are kept, and how many it traced and reused.
pub struct ReferenceStore {
    dir: PathBuf,
    /// The scene's content key (`Scene::content_key`): every key starts with it.
    scene: String,
    /// Sets traced, and sets read back.
    traced: AtomicU64,
    reused: AtomicU64,
    /// Trace every set again (and store it), reading none back (`--force`).
    retrace: bool,
}

/// What a set of references depends on, hashed: the scene's content, what the set is, and
/// every parameter the caller adds.
pub struct Key(Fnv);

impl Key {
    /// Adds `words` (bits of floats, counts, seeds).
    #[must_use]
    pub fn words(mut self, words: impl IntoIterator<Item = u64>) -> Key {
        for w in words {
            self.0.update(&w.to_le_bytes());
        }
        self
    }

    /// Adds the bits of `v`.
    #[must_use]
    pub fn vec3s(self, v: &[Vec3]) -> Key {
        self.words(v.iter().flat_map(|p| p.to_array().map(|x| u64::from(x.to_bits()))))
    }

    fn name(&self, what: &str) -> String {
        format!("{what}-{}.bin", self.0.finish().trim_start_matches("fnv1a64:"))
    }
}

impl ReferenceStore {
    /// The store of the bake folder `bake` for a scene of content key `scene`.
    #[must_use]
    pub fn new(bake: &Path, scene: &str) -> ReferenceStore {
        ReferenceStore {
            dir: bake.join("references"),
            scene: scene.to_string(),
            traced: AtomicU64::new(0),
            reused: AtomicU64::new(0),
            retrace: false,
        }
    }

    /// From now on every set is traced again and stored, none read back.
    pub fn retrace(&mut self) {
        self.retrace = true;
    }

    /// The key of a set named `what`.
    #[must_use]
    pub fn key(&self, what: &str) -> Key {
        let mut h = Fnv::new();
        h.update(self.scene.as_bytes());
        h.update(&[0]);
        h.update(what.as_bytes());
        Key(h)
    }

    /// (sets traced, sets reused) so far.
    #[must_use]
    pub fn counts(&self) -> (u64, u64) {
        (self.traced.load(Ordering::Relaxed), self.reused.load(Ordering::Relaxed))
    }

    /// Set `what` with key `key`: read back (`from` its words) when stored whole, else
    /// `trace()`d and stored as `to` gives its words (a failure to store is logged: the run
    /// goes on without keeping it).
    pub fn cached<T>(
        &self,
        what: &str,
        key: Key,
        (to, from): (impl Fn(&T) -> Vec<u32>, impl Fn(&[u32]) -> Option<T>),
        trace: impl FnOnce() -> T,
    ) -> T {
        let path = self.dir.join(key.name(what));
        let id = key.0.finish();
        if let Some(v) = (!self.retrace).then(|| read(&path, &id)).flatten().and_then(|w| from(&w)) {
            self.reused.fetch_add(1, Ordering::Relaxed);
            return v;
        }
        let v = trace();
        self.traced.fetch_add(1, Ordering::Relaxed);
        let stored = std::fs::create_dir_all(&self.dir)
            .map_err(FileError::io(&self.dir))
            .and_then(|()| crate::files::write_atomic(&path, &encode(&id, &to(&v))));
        if let Err(e) = stored {
            tracing::warn!("traced references not kept for the next run: {e}");
        }
        v
    }
}

/// The file's bytes: magic, key, word count, the words, then the checksum of all before.
fn encode(id: &str, words: &[u32]) -> Vec<u8> {
    let mut b = Vec::with_capacity(MAGIC.len() + 40 + words.len() * 4);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&(id.len() as u64).to_le_bytes());
    b.extend_from_slice(id.as_bytes());
    b.extend_from_slice(&(words.len() as u64).to_le_bytes());
    for w in words {
        b.extend_from_slice(&w.to_le_bytes());
    }
    let mut h = Fnv::new();
    h.update(&b);
    let sum = h.finish();
    b.extend_from_slice(sum.as_bytes());
    b
}

/// The words stored at `path` under key `id`, if the file is whole and its own.
fn read(path: &Path, id: &str) -> Option<Vec<u32>> {
    let bytes = std::fs::read(path).ok()?;
    let sum_len = Fnv::new().finish().len();
    let (body, sum) = bytes.split_at_checked(bytes.len().checked_sub(sum_len)?)?;
    let mut h = Fnv::new();
    h.update(body);
    if h.finish().as_bytes() != sum {
        tracing::warn!("{}: damaged (checksum), traced again", path.display());
        return None;
    }
    let rest = body.strip_prefix(MAGIC)?;
    let (n, rest) = rest.split_first_chunk::<8>()?;
    let (key, rest) = rest.split_at_checked(u64::from_le_bytes(*n) as usize)?;
    let (count, rest) = rest.split_first_chunk::<8>()?;
    if key != id.as_bytes() || rest.len() as u64 != u64::from_le_bytes(*count).checked_mul(4)? {
        return None;
    }
    Some(rest.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

/// One number as words (its bits, low half first).
pub fn f64_to_words(x: &f64) -> Vec<u32> {
    let bits = x.to_bits();
    vec![bits as u32, (bits >> 32) as u32]
}

/// [`f64_to_words`] read back: `None` unless exactly two words.
pub fn f64_from_words(w: &[u32]) -> Option<f64> {
    match *w {
        [lo, hi] => Some(f64::from_bits(u64::from(lo) | u64::from(hi) << 32)),
        _ => None,
    }
}

/// A set of traced queries as words (every float's bits).
#[must_use]
pub fn queries_to_words(q: &TracedQueries) -> Vec<u32> {
    let (n, np) = (q.dirs.len(), q.positions.len());
    let mut w = Vec::with_capacity(5 + 3 * np + n * 11);
    w.extend([n as u32, q.dirs_per_position as u32, (q.rays >> 32) as u32, q.rays as u32, np as u32]);
    let v3 = |w: &mut Vec<u32>, v: &[Vec3]| w.extend(v.iter().flat_map(|x| x.to_array().map(f32::to_bits)));
    v3(&mut w, &q.positions);
    v3(&mut w, &q.dirs);
    w.extend(q.roughness.iter().map(|x| x.to_bits()));
    v3(&mut w, &q.reference);
    w.extend(q.reference_se.iter().map(|x| x.to_bits()));
    v3(&mut w, &q.emitted);
    w
}

/// [`queries_to_words`] read back; `None` when the words are not such a set.
#[must_use]
pub fn queries_from_words(w: &[u32]) -> Option<TracedQueries> {
    let (&[n, dpp, hi, lo, np], rest) = w.split_first_chunk::<5>()?;
    let (n, dpp, np) = (n as usize, dpp as usize, np as usize);
    if rest.len() != 3 * np + n * 11 || n != np * dpp {
        return None;
    }
    let f = |s: &[u32]| s.iter().map(|&b| f32::from_bits(b)).collect::<Vec<f32>>();
    let v3 = |s: &[u32]| {
        s.chunks_exact(3)
            .map(|c| Vec3::new(f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2])))
            .collect::<Vec<Vec3>>()
    };
    let (positions, rest) = rest.split_at(3 * np);
    let (dirs, rest) = rest.split_at(3 * n);
    let (roughness, rest) = rest.split_at(n);
    let (reference, rest) = rest.split_at(3 * n);
    let (reference_se, emitted) = rest.split_at(n);
    Some(TracedQueries {
        positions: v3(positions),
        dirs: v3(dirs),
        dirs_per_position: dpp,
        roughness: f(roughness),
        reference: v3(reference),
        reference_se: f(reference_se),
        emitted: v3(emitted),
        rays: (u64::from(hi) << 32) | u64::from(lo),
    })
}

/// Pairs of vectors (a view's reference halves) as words.
#[must_use]
pub fn pairs_to_words(p: &[(Vec3, Vec3)]) -> Vec<u32> {
    p.iter().flat_map(|(a, b)| a.to_array().into_iter().chain(b.to_array()).map(f32::to_bits)).collect()
}

/// [`pairs_to_words`] read back; `None` unless there are `len` of them.
#[must_use]
pub fn pairs_from_words(w: &[u32], len: usize) -> Option<Vec<(Vec3, Vec3)>> {
    if w.len() != len * 6 {
        return None;
    }
    let v = |c: &[u32]| Vec3::new(f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2]));
    Some(w.chunks_exact(6).map(|c| (v(&c[..3]), v(&c[3..]))).collect())
}

/// Vectors with the rays traced for them (a set of irradiance references) as words.
#[must_use]
pub fn traced_to_words((v, rays): &(Vec<Vec3>, u64)) -> Vec<u32> {
    let mut w = vec![(rays >> 32) as u32, *rays as u32];
    w.extend(v.iter().flat_map(|x| x.to_array().map(f32::to_bits)));
    w
}

/// [`traced_to_words`] read back; `None` unless it holds `len` vectors.
#[must_use]
pub fn traced_from_words(w: &[u32], len: usize) -> Option<(Vec<Vec3>, u64)> {
    let (&[hi, lo], rest) = w.split_first_chunk::<2>()?;
    if rest.len() != 3 * len {
        return None;
    }
    let v = rest.chunks_exact(3).map(|c| Vec3::new(f32::from_bits(c[0]), f32::from_bits(c[1]), f32::from_bits(c[2])));
    Some((v.collect(), (u64::from(hi) << 32) | u64::from(lo)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A number comes back bit for bit, and a set of another length is not one.
    #[test]
    fn a_number_round_trips_through_its_words() {
        for x in [0.0, -0.0, 0.4375, 1.0, f64::MIN_POSITIVE, f64::MAX, f64::NAN] {
            let back = f64_from_words(&f64_to_words(&x)).map(f64::to_bits);
            assert_eq!(back, Some(x.to_bits()), "{x}");
        }
        assert_eq!(f64_from_words(&[1]), None);
        assert_eq!(f64_from_words(&[1, 2, 3]), None);
    }
}
