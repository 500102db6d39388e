//! `samples.bin`: the core's input, tick by tick ([the format](super)).

use std::io::Read;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::control::Tick;
use crate::control::imu::{CHANNELS, ImuInput, ImuSample};
use crate::control::sample::Sample;
use crate::control::tick::{ArmInput, ArmPose, TickInput};
use crate::tools::recording::format::{Bytes, FormatError, Stream, op};

const VALUE: u8 = 0x01;
const REPEAT: u8 = 0x02;
const MISSING: u8 = 0x03;
const GAP: u8 = 0x04;
const AT_TICK: u8 = 0x05;
const STOP: u8 = 0x06;
const LOST_TICKS: u8 = 0x07;
const DISCONNECTED: u8 = 0x08;
const START_POSE: u8 = 0x09;
const MEASURED_POSE: u8 = 0x0a;
const LINK_LOST: u8 = 0x0b;
const IMU_SAMPLE: u8 = 0x0c;
const IMU_LOST: u8 = 0x0d;

/// A pose as the 7 `f64`s stored: x, y, z, then the quaternion i, j, k, w.
fn pose_bits(pose: &Isometry3<f64>) -> [u64; 7] {
    let t = pose.translation.vector;
    let q = pose.rotation.quaternion().coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w].map(f64::to_bits)
}

/// The pose the 7 stored `f64`s give back, bit for bit.
fn pose_from_bits(bits: [u64; 7]) -> Isometry3<f64> {
    let [x, y, z, i, j, k, w] = bits.map(f64::from_bits);
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        // Stored from a unit quaternion: taken back as it is (normalising
        // would change the last bits).
        UnitQuaternion::new_unchecked(Quaternion::new(w, i, j, k)),
    )
}

/// Encodes the core's inputs into `samples.bin` ops (not the header or
/// end marker: [`StreamFile`](super::StreamFile) writes those). A run of
/// ticks of one kind (repeating the last value, without a sample, with
/// the device gone) is held until it ends; [`SampleEncoder::flush`]
/// writes it out.
#[derive(Debug, Default)]
pub struct SampleEncoder {
    next_tick: Tick,
    last_bits: Option<u64>,
    /// The run held: its op and its ticks.
    run: Option<(u8, u64)>,
}

impl SampleEncoder {
    /// Appends one tick's input.
    pub fn input(&mut self, out: &mut Vec<u8>, input: &TickInput) {
        if input.tick != self.next_tick {
            self.flush(out);
            if input.tick > self.next_tick {
                op(out, GAP, input.tick - self.next_tick);
            } else {
                op(out, AT_TICK, input.tick);
            }
        }
        if !input.arm.is_empty() || input.stop || input.imu != ImuInput::Missing {
            self.flush(out);
            match input.imu {
                ImuInput::Sample(sample) => {
                    out.push(IMU_SAMPLE);
                    for v in sample.values {
                        out.extend_from_slice(&v.to_bits().to_le_bytes());
                    }
                }
                ImuInput::Lost => out.push(IMU_LOST),
                ImuInput::Missing => {}
            }
            if let Some((kind, pose)) = &input.arm.pose {
                out.push(match kind {
                    ArmPose::Start => START_POSE,
                    ArmPose::Measured => MEASURED_POSE,
                });
                for b in pose_bits(pose) {
                    out.extend_from_slice(&b.to_le_bytes());
                }
            }
            if input.arm.link_lost {
                out.push(LINK_LOST);
            }
            if input.stop {
                out.push(STOP);
            }
        }
        let kind = match input.sample {
            Sample::Volts(v) if self.last_bits == Some(v.to_bits()) => REPEAT,
            Sample::Volts(v) => {
                self.flush(out);
                out.push(VALUE);
                out.extend_from_slice(&v.to_bits().to_le_bytes());
                self.last_bits = Some(v.to_bits());
                VALUE
            }
            Sample::Missing => MISSING,
            Sample::Lost => DISCONNECTED,
        };
        if kind != VALUE {
            match &mut self.run {
                Some((held, n)) if *held == kind => *n += 1,
                _ => {
                    self.flush(out);
                    self.run = Some((kind, 1));
                }
            }
        }
        self.next_tick = input.tick.wrapping_add(1);
    }

    /// Appends a mark for `n` ticks that were lost before reaching the
    /// recording.
    pub fn lost(&mut self, out: &mut Vec<u8>, n: u64) {
        if n > 0 {
            self.flush(out);
            op(out, LOST_TICKS, n);
        }
    }

    /// Ticks in the run held (not yet in the ops).
    pub fn held(&self) -> u64 {
        self.run.map_or(0, |(_, n)| n)
    }

    /// Writes out the run held.
    pub fn flush(&mut self, out: &mut Vec<u8>) {
        if let Some((kind, n)) = self.run.take() {
            op(out, kind, n);
        }
    }
}

/// One item of `samples.bin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SampleItem {
    /// One tick's whole input.
    Input(TickInput),
    /// Ticks lost before reaching the recording: what follows is not the
    /// core's whole input.
    Lost(u64),
}

/// Reads `samples.bin`, item by item, as a stream (an hour of recording
/// never sits in memory).
pub struct SampleDecoder<R: Read> {
    bytes: Bytes<R>,
    next_tick: Tick,
    last: Option<f64>,
    /// Ticks left of a run: (count, sample).
    run: Option<(u64, Sample)>,
    /// What the arm said before the next tick.
    arm: ArmInput,
    /// The safe stop begins on the next tick.
    stop: bool,
    /// What the IMU gave on the next tick.
    imu: ImuInput,
    ended: bool,
}

impl<R: Read> SampleDecoder<R> {
    /// Reads and checks the header.
    pub fn new(input: R) -> Result<Self, FormatError> {
        let mut bytes = Bytes::new(input);
        bytes.header(Stream::Samples)?;
        Ok(SampleDecoder {
            bytes,
            next_tick: 0,
            last: None,
            run: None,
            arm: ArmInput::default(),
            stop: false,
            imu: ImuInput::Missing,
            ended: false,
        })
    }

    fn tick(&mut self, sample: Sample) -> SampleItem {
        let tick = self.next_tick;
        self.next_tick = tick.wrapping_add(1);
        let arm = if self.arm.is_empty() {
            ArmInput::default()
        } else {
            std::mem::take(&mut self.arm)
        };
        SampleItem::Input(TickInput {
            tick,
            sample,
            arm,
            stop: std::mem::take(&mut self.stop),
            imu: std::mem::take(&mut self.imu),
        })
    }

    /// The next item; `Ok(None)` after a valid end marker.
    pub fn next_item(&mut self) -> Result<Option<SampleItem>, FormatError> {
        if let Some((left, sample)) = self.run {
            self.run = (left > 1).then_some((left - 1, sample));
            return Ok(Some(self.tick(sample)));
        }
        // A new value, whole in the buffer: most ticks of an analog sensor.
        if let Some(bits) = self.bytes.take_u64_op(VALUE) {
            let v = f64::from_bits(bits);
            self.last = Some(v);
            return Ok(Some(self.tick(Sample::Volts(v))));
        }
        self.next_op()
    }

    /// [`SampleDecoder::next_item`] from the next op, read the long way.
    fn next_op(&mut self) -> Result<Option<SampleItem>, FormatError> {
        if self.ended {
            return Ok(None);
        }
        loop {
            let tag = self.bytes.tag()?;
            match tag {
                VALUE => {
                    let v = f64::from_bits(self.bytes.u64le()?);
                    self.last = Some(v);
                    return Ok(Some(self.tick(Sample::Volts(v))));
                }
                REPEAT | MISSING | DISCONNECTED => {
                    let n = self.bytes.count("a run")?;
                    let sample = match tag {
                        MISSING => Sample::Missing,
                        DISCONNECTED => Sample::Lost,
                        _ => Sample::Volts(self.last.ok_or_else(|| {
                            self.bytes
                                .error("a repeat before any value (the file is corrupted)")
                        })?),
                    };
                    self.run = (n > 1).then_some((n - 1, sample));
                    return Ok(Some(self.tick(sample)));
                }
                GAP => {
                    let n = self.bytes.count("a gap")?;
                    self.next_tick = self.next_tick.wrapping_add(n);
                }
                AT_TICK => self.next_tick = self.bytes.varint()?,
                START_POSE | MEASURED_POSE => {
                    let mut bits = [0u64; 7];
                    for b in &mut bits {
                        *b = self.bytes.u64le()?;
                    }
                    let kind = if tag == START_POSE {
                        ArmPose::Start
                    } else {
                        ArmPose::Measured
                    };
                    self.arm.pose = Some((kind, pose_from_bits(bits)));
                }
                LINK_LOST => self.arm.link_lost = true,
                IMU_SAMPLE => {
                    let mut values = [0.0; CHANNELS];
                    for v in &mut values {
                        *v = f64::from_bits(self.bytes.u64le()?);
                    }
                    self.imu = ImuInput::Sample(ImuSample { values });
                }
                IMU_LOST => self.imu = ImuInput::Lost,
                STOP => self.stop = true,
                _ => {
                    let lost = self.bytes.loss_or_end(tag, LOST_TICKS)?;
                    self.ended = lost.is_none();
                    return Ok(lost.map(SampleItem::Lost));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tools::recording::format::StreamFile;

    fn input(tick: Tick, volts: Option<f64>) -> TickInput {
        TickInput::new(tick, volts.map_or(Sample::Missing, Sample::Volts))
    }

    fn encode_samples(inputs: &[TickInput]) -> Vec<u8> {
        let mut file = StreamFile::start(Vec::new(), Stream::Samples).unwrap();
        let mut enc = SampleEncoder::default();
        let mut ops = Vec::new();
        for i in inputs {
            enc.input(&mut ops, i);
        }
        enc.flush(&mut ops);
        file.write(&ops).unwrap();
        file.end().unwrap()
    }

    fn decode_samples(bytes: &[u8]) -> Result<Vec<SampleItem>, FormatError> {
        let mut dec = SampleDecoder::new(bytes)?;
        let mut out = Vec::new();
        while let Some(item) = dec.next_item()? {
            out.push(item);
        }
        Ok(out)
    }

    #[test]
    fn imu_samples_and_its_loss_survive_bit_for_bit_among_runs() {
        let imu = |v: f64| {
            ImuInput::Sample(ImuSample {
                values: [
                    v,
                    -0.0,
                    9.81,
                    f64::from_bits(0x7ff8_0000_0000_0001),
                    1e-300,
                    -v,
                ],
            })
        };
        // A person fed by the IMU alone: no breath sample on any tick, an
        // IMU sample every 10 ticks, the device gone at the end.
        let mut inputs: Vec<TickInput> = (0..40)
            .map(|t| {
                let sample = if t % 10 == 0 {
                    imu(t as f64 / 3.0)
                } else {
                    ImuInput::Missing
                };
                TickInput::imu(t, sample)
            })
            .collect();
        inputs.push(TickInput::imu(40, ImuInput::Lost));
        inputs.push(TickInput::imu(41, ImuInput::Missing));
        let bytes = encode_samples(&inputs);
        // Each sample: its op and 48 bytes, then the tick's own run.
        assert!(
            bytes.len() < 10 + 4 * (1 + 48 + 2) + 2 + 2 + 5,
            "{}",
            bytes.len()
        );
        let items = decode_samples(&bytes).unwrap();
        let decoded: Vec<TickInput> = items
            .iter()
            .map(|item| match item {
                SampleItem::Input(input) => *input,
                SampleItem::Lost(n) => panic!("lost {n}"),
            })
            .collect();
        assert_eq!(decoded.len(), inputs.len());
        for (d, i) in decoded.iter().zip(&inputs) {
            // Compared by bits: NaN is in the samples.
            assert_eq!(format!("{d:?}"), format!("{i:?}"));
            if let (ImuInput::Sample(a), ImuInput::Sample(b)) = (d.imu, i.imu) {
                assert_eq!(a.values.map(f64::to_bits), b.values.map(f64::to_bits));
            }
        }
    }

    #[test]
    fn a_held_value_costs_one_run() {
        let inputs: Vec<TickInput> = (0..10_000).map(|t| input(t, Some(2.5))).collect();
        let bytes = encode_samples(&inputs);
        // Header, one value, one run of 9999, the end marker.
        assert_eq!(bytes.len(), 10 + 9 + 3 + 5, "{bytes:?}");
        let items = decode_samples(&bytes).unwrap();
        assert_eq!(items.len(), 10_000);
        assert_eq!(
            items[9_999],
            SampleItem::Input(TickInput::volts(9_999, 2.5))
        );
    }

    #[test]
    fn gaps_missing_runs_stops_and_bits_survive() {
        let nan = f64::from_bits(0x7ff8_0000_dead_beef);
        let gone = |tick| TickInput::new(tick, Sample::Lost);
        let mut inputs = vec![
            input(5, Some(-0.0)),
            input(6, Some(0.0)),
            input(7, None),
            input(8, None),
            gone(9),
            gone(10),
            input(11, None),
            input(2008, Some(nan)),
            input(2009, Some(nan)),
            input(3, Some(1.0)),
        ];
        inputs[8].stop = true;
        // The arm's news, in the middle of runs too: a start pose (an
        // awkward quaternion: its bits must survive), a measurement, a lost
        // link with a measurement.
        let q = nalgebra::UnitQuaternion::from_scaled_axis(nalgebra::Vector3::new(0.1, -2.0, 0.3));
        let pose = |x: f64| Isometry3::from_parts(Translation3::new(x, -0.26, 1.0 / 3.0), q);
        inputs[0].arm.pose = Some((ArmPose::Start, pose(0.21)));
        inputs[3].arm.pose = Some((ArmPose::Measured, pose(-0.0)));
        inputs[5].arm = ArmInput {
            pose: Some((ArmPose::Measured, pose(0.3))),
            link_lost: true,
        };
        let bytes = encode_samples(&inputs);
        let items = decode_samples(&bytes).unwrap();
        let back: Vec<TickInput> = items
            .into_iter()
            .map(|item| match item {
                SampleItem::Input(input) => input,
                SampleItem::Lost(_) => panic!("nothing was lost"),
            })
            .collect();
        assert_eq!(back.len(), inputs.len());
        for (a, b) in back.iter().zip(&inputs) {
            assert_eq!((a.tick, a.stop), (b.tick, b.stop));
            let arm_bits = |arm: &ArmInput| {
                (
                    arm.pose.map(|(kind, pose)| (kind, pose_bits(&pose))),
                    arm.link_lost,
                )
            };
            assert_eq!(arm_bits(&a.arm), arm_bits(&b.arm));
            let bits = |s: Sample| match s {
                Sample::Volts(v) => (0, v.to_bits()),
                Sample::Missing => (1, 0),
                Sample::Lost => (2, 0),
            };
            assert_eq!(bits(a.sample), bits(b.sample));
        }
    }

    #[test]
    fn a_stop_written_after_a_tick_begins_on_the_next() {
        // The layout of files whose writer put the stop after the tick that
        // decided it, before a gap: the next tick's input carries it.
        let mut ops = vec![VALUE];
        ops.extend_from_slice(&2.5f64.to_bits().to_le_bytes());
        ops.push(STOP);
        op(&mut ops, GAP, 5);
        ops.push(VALUE);
        ops.extend_from_slice(&2.6f64.to_bits().to_le_bytes());
        let mut file = StreamFile::start(Vec::new(), Stream::Samples).unwrap();
        file.write(&ops).unwrap();
        let items = decode_samples(&file.end().unwrap()).unwrap();
        let stopping = TickInput {
            stop: true,
            ..TickInput::volts(6, 2.6)
        };
        assert_eq!(
            items,
            [
                SampleItem::Input(TickInput::volts(0, 2.5)),
                SampleItem::Input(stopping)
            ]
        );
        // Written today: the stop with the tick it begins on, same items.
        let inputs = [TickInput::volts(0, 2.5), stopping];
        assert_eq!(decode_samples(&encode_samples(&inputs)).unwrap(), items);
    }

    #[test]
    fn truncation_and_corruption_name_the_offset() {
        let inputs: Vec<TickInput> = (0..100)
            .map(|t| input(t, Some(f64::from(t as u32) * 0.01)))
            .collect();
        let bytes = encode_samples(&inputs);
        let e = decode_samples(&bytes[..bytes.len() - 5]).unwrap_err();
        assert_eq!(e.offset, bytes.len() as u64 - 5);
        assert!(e.message.contains("no end marker"), "{e}");
        let e = decode_samples(&bytes[..bytes.len() - 2]).unwrap_err();
        assert!(e.message.contains("ends inside this op"), "{e}");
        // A flipped bit in a value: only the checksum can tell.
        let mut bad = bytes.clone();
        bad[10 + 9 * 50 + 3] ^= 0x10;
        let e = decode_samples(&bad).unwrap_err();
        assert_eq!(e.offset, bytes.len() as u64 - 5);
        assert!(e.message.contains("checksum mismatch"), "{e}");
        // A flipped op: named where it is.
        let mut bad = bytes.clone();
        bad[10 + 9 * 50] = 0x42;
        let e = decode_samples(&bad).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "offset {}: unknown op 0x42 (the file is corrupted)",
                10 + 9 * 50
            )
        );
        let mut extra = bytes.clone();
        extra.push(0);
        assert!(
            decode_samples(&extra)
                .unwrap_err()
                .message
                .contains("1 bytes after the end marker")
        );
        let e = decode_samples(b"SIPNPUFFC\x01").unwrap_err();
        assert!(e.message.contains("holds the commands stream"), "{e}");
        let e = decode_samples(b"SIPNPUFFS\x09").unwrap_err();
        assert!(e.message.contains("format version 9"), "{e}");
        let e = decode_samples(b"tick,volts\n").unwrap_err();
        assert!(e.message.contains("no SIPNPUFF header"), "{e}");
        assert!(
            decode_samples(b"")
                .unwrap_err()
                .message
                .contains("too short")
        );
    }

    #[test]
    fn a_varint_past_64_bits_is_an_error() {
        let mut bytes = Stream::Samples.header().to_vec();
        bytes.push(REPEAT);
        bytes.extend([0xff; 10]);
        let e = decode_samples(&bytes).unwrap_err();
        assert_eq!(e.offset, 10);
        assert!(e.message.contains("longer than 64 bits"), "{e}");
        let mut bytes = Stream::Samples.header().to_vec();
        bytes.extend([REPEAT, 3]);
        assert!(
            decode_samples(&bytes)
                .unwrap_err()
                .message
                .contains("a repeat before any value")
        );
    }
}
