//! The octrees' occupancy bytes ([`super::octree`]) arithmetic-coded bit by bit, as Draco and
//! MPEG G-PCC code point-set geometry: each byte is eight yes-or-no answers ("is child `b`
//! occupied?"), each coded by `constriction`'s range coder with the probability its context has
//! learnt so far. A context is the node's depth in its octree (depths from 15 share one), the
//! child's index and how many of the node's children before it are occupied (0, 1, 2, or 3 and
//! more); the eighth child of a node whose first seven are empty is occupied and costs nothing.
//! Every octree starts from even odds. A probability is `(2 ones + 1) / (2 ones + 2 zeros + 2)`
//! in 24-bit fixed point, the counts halved (rounding up) when their sum passes 4,096; the coder
//! is `constriction`'s default range coder (64-bit state, 32-bit words written little-endian).
//! These numbers are the file format: a test holds the bytes of a fixed octree.
//!
//! Near the root most children are occupied, near the leaves one of eight: the contexts learn
//! both, where zstd over the bytes sees symbols of nearly uniform frequency (the bytes saved
//! are measured in docs/method.md, "Compact by construction").

use std::borrow::Borrow;
use std::num::NonZeroU32;

use constriction::stream::model::{DecoderModel, EncoderModel, EntropyModel};
use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

/// Fixed-point bits of a probability.
const PRECISION: usize = 24;

/// Depths beyond this share the deepest depth's contexts.
const DEPTHS: usize = 16;

/// Counts of occupied children before this one that make a context of their own (0, 1, 2, 3
/// or more).
const SEEN: usize = 4;

/// A context's counts are halved when their sum passes this, so that it follows the octree's
/// statistics as they change from level to level.
const MEMORY: u32 = 4096;

/// The adaptive probability of one context: twice the number of ones and of zeros it has
/// seen, plus one each (Krichevsky-Trofimov's estimator).
#[derive(Clone, Copy)]
struct Context {
    zeros: u32,
    ones: u32,
}

impl Context {
    const EVEN: Context = Context { zeros: 1, ones: 1 };

    /// The probability of a one, in fixed point, within `[1, 2^PRECISION - 1]`.
    fn model(self) -> Bit {
        let total = u64::from(self.zeros) + u64::from(self.ones);
        let one = (u64::from(self.ones) << PRECISION) / total;
        Bit { one: one.clamp(1, (1 << PRECISION) - 1) as u32 }
    }

    fn learn(&mut self, bit: bool) {
        if bit {
            self.ones += 2;
        } else {
            self.zeros += 2;
        }
        if self.zeros + self.ones > MEMORY {
            self.zeros = self.zeros.div_ceil(2);
            self.ones = self.ones.div_ceil(2);
        }
    }
}

/// A yes-or-no answer with probability `one / 2^PRECISION` of yes: the entropy model the range
/// coder reads.
struct Bit {
    one: u32,
}

impl Bit {
    fn zero(&self) -> u32 {
        (1 << PRECISION) - self.one
    }
}

impl EntropyModel<PRECISION> for Bit {
    type Symbol = bool;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for Bit {
    fn left_cumulative_and_probability(
        &self,
        symbol: impl Borrow<bool>,
    ) -> Option<(u32, NonZeroU32)> {
        Some(if *symbol.borrow() {
            (self.zero(), NonZeroU32::new(self.one)?)
        } else {
            (0, NonZeroU32::new(self.zero())?)
        })
    }
}

impl DecoderModel<PRECISION> for Bit {
    fn quantile_function(&self, quantile: u32) -> (bool, u32, NonZeroU32) {
        // Both probabilities lie in [1, 2^PRECISION - 1] (`Context::model`).
        let nonzero = |p| NonZeroU32::new(p).unwrap_or(NonZeroU32::MIN);
        if quantile < self.zero() {
            (false, 0, nonzero(self.zero()))
        } else {
            (true, self.zero(), nonzero(self.one))
        }
    }
}

/// The contexts of one octree.
struct Contexts(Vec<Context>);

impl Contexts {
    fn new() -> Contexts {
        Contexts(vec![Context::EVEN; DEPTHS * 8 * SEEN])
    }

    fn at(&mut self, depth: u32, child: u32, seen: u32) -> &mut Context {
        let depth = (depth as usize).min(DEPTHS - 1);
        let seen = (seen as usize).min(SEEN - 1);
        &mut self.0[(depth * 8 + child as usize) * SEEN + seen]
    }

    /// Whether child `child` of a node whose first children held `seen` occupied ones is coded
    /// at all: the last child of a node with none before it is occupied.
    fn coded(child: u32, seen: u32) -> bool {
        !(child == 7 && seen == 0)
    }
}

/// Codes octrees one after another.
pub(crate) struct Encoder {
    coder: DefaultRangeEncoder,
    contexts: Contexts,
    octrees: usize,
}

impl Default for Encoder {
    fn default() -> Encoder {
        Encoder { coder: DefaultRangeEncoder::new(), contexts: Contexts::new(), octrees: 0 }
    }
}

impl Encoder {
    /// Whether no octree was coded.
    pub(crate) fn is_empty(&self) -> bool {
        self.octrees == 0
    }

    /// Codes the occupancy bytes `masks` of one octree (breadth first, as
    /// [`super::octree::encode`] writes them).
    pub(crate) fn octree(&mut self, masks: &[u8]) {
        self.contexts = Contexts::new();
        self.octrees += 1;
        for (depth, mask) in super::octree::depths(masks) {
            let mut seen = 0;
            for child in 0..8 {
                let bit = mask >> child & 1 == 1;
                if Contexts::coded(child, seen) {
                    let context = self.contexts.at(depth, child, seen);
                    self.coder
                        .encode_symbol(bit, context.model())
                        .expect("every answer has a nonzero probability; the backend is a vector");
                    context.learn(bit);
                }
                seen += u32::from(bit);
            }
        }
    }

    /// The coded bytes: the range coder's 32-bit words, little-endian.
    pub(crate) fn finish(self) -> Vec<u8> {
        let words = self.coder.into_compressed().unwrap_or_default();
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }
}

/// Reads octrees coded by [`Encoder`], in the same order.
pub(crate) struct Decoder {
    coder: DefaultRangeDecoder,
    contexts: Contexts,
}

impl Decoder {
    /// A decoder of `bytes`.
    ///
    /// # Errors
    /// A message when the bytes are not whole 32-bit words.
    pub(crate) fn new(bytes: &[u8]) -> Result<Decoder, String> {
        if !bytes.len().is_multiple_of(4) {
            return Err(format!("the coded occupancy has {} bytes, not whole words", bytes.len()));
        }
        let words: Vec<u32> =
            bytes.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect();
        let coder = DefaultRangeDecoder::from_compressed(words)
            .map_err(|_| "the coded occupancy cannot be read".to_string())?;
        Ok(Decoder { coder, contexts: Contexts::new() })
    }

    /// Starts the next octree.
    pub(crate) fn start_octree(&mut self) {
        self.contexts = Contexts::new();
    }

    /// The occupancy byte of the next node, at `depth` in its octree.
    ///
    /// # Errors
    /// A message when the coded bits are not a valid code.
    pub(crate) fn mask(&mut self, depth: u32) -> Result<u8, String> {
        let mut mask = 0u8;
        let mut seen = 0;
        for child in 0..8 {
            let bit = if Contexts::coded(child, seen) {
                let context = self.contexts.at(depth, child, seen);
                let bit = self
                    .coder
                    .decode_symbol(context.model())
                    .map_err(|_| "the coded occupancy is not valid".to_string())?;
                context.learn(bit);
                bit
            } else {
                true
            };
            mask |= u8::from(bit) << child;
            seen += u32::from(bit);
        }
        Ok(mask)
    }

    /// Whether every coded word was read (an encoder's output read to its end).
    pub(crate) fn is_done(&self) -> bool {
        self.coder.maybe_exhausted()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Octrees of points on a sphere and of a few scattered points come back as coded, in
    /// fewer bytes than one per node.
    #[test]
    fn octrees_come_back_as_coded() {
        let sphere: Vec<[u64; 3]> = {
            let mut points: Vec<[u64; 3]> = (0..3000)
                .map(|i| {
                    let z = 1.0 - 2.0 * (i as f64 + 0.5) / 3000.0;
                    let a = i as f64 * 2.399_963;
                    let r = (1.0 - z * z).sqrt();
                    [r * a.cos(), r * a.sin(), z].map(|v| ((v + 1.0) * 500.0) as u64)
                })
                .collect();
            points.sort_by_key(|&p| crate::geometry::morton_key(p));
            points.dedup();
            points
        };
        let scattered = vec![[0, 0, 0], [5, 1, 3], [7, 7, 7]];
        let sets = [(sphere, 10), (scattered, 3)];
        let masks: Vec<Vec<u8>> = sets
            .iter()
            .map(|(points, depth)| super::super::octree::encode(points, *depth))
            .collect();
        let mut encoder = Encoder::default();
        masks.iter().for_each(|m| encoder.octree(m));
        let bytes = encoder.finish();
        let nodes: usize = masks.iter().map(Vec::len).sum();
        assert!(bytes.len() * 10 < nodes * 8, "{} bytes for {nodes} nodes", bytes.len());
        let mut decoder = Decoder::new(&bytes).unwrap();
        for (points, depth) in &sets {
            decoder.start_octree();
            let back = super::super::octree::decode(|d| decoder.mask(d), *depth, points.len());
            assert_eq!(back.unwrap(), *points);
        }
        assert!(decoder.is_done());
    }

    /// The coded bytes of a fixed octree, which any change to the contexts, the probabilities or
    /// the coder would change: files already written must keep reading.
    #[test]
    fn the_coding_of_a_fixed_octree_is_the_format() {
        let mut points: Vec<[u64; 3]> =
            (0..40u64).map(|i| [(i * 5) % 16, (i * 3) % 16, (i * i) % 16]).collect();
        points.sort_by_key(|&p| crate::geometry::morton_key(p));
        points.dedup();
        let mut encoder = Encoder::default();
        encoder.octree(&super::super::octree::encode(&points, 4));
        let bytes = encoder.finish();
        assert_eq!(points.len(), 16);
        let golden = [
            7, 20, 168, 235, 199, 235, 137, 78, 19, 193, 177, 108, 144, 48, 228, 251, 215, 102,
            170, 172, 167, 73, 59, 35,
        ];
        assert_eq!(bytes, golden);
    }
}
