//! `--arm ros2:TOPIC`: the 100 Hz stream as a ROS 2 topic, from a
//! pure-Rust DDS participant (`rustdds`), under the names ROS 2 gives its
//! topics and types (`rt/<topic>`, `<package>::msg::dds_::<Type>_`), so a
//! node on any RMW over DDS (Cyclone DDS, Fast DDS) subscribes to it as
//! to any ROS 2 publisher: MoveIt Servo's `~/delta_twist_cmds`,
//! ros2_kortex's twist controller, a JACO2 ROS 2 port's
//! `in/cartesian_velocity`. Not RT-safe: called from the arm thread.
//!
//! - **QoS** ([`qos`]): the commands reliable, volatile, keep-last 10 —
//!   rclcpp's default, what Servo and the controllers subscribe with; the
//!   pose best effort (matches a reliable or a best-effort publisher).
//! - **Connect**: waits, up to `[arm] connect_timeout_ms`, for a matched
//!   subscriber, then for that subscriber to acknowledge a zero command
//!   (so it has matched us too: what it is sent from then on reaches it),
//!   then, with a pose topic, for the first pose.
//! - **Link**: the writer's matched subscribers falling to none (the
//!   receiver left, or its lease ran out), or the receiver leaving
//!   [`qos::ACK_WINDOW`] commands unacknowledged (0.5 s: a receiver killed
//!   without a goodbye), is `ArmError::Disconnected`, from `check_link`
//!   and from the next `send`.
//! - **Stop**: the zero command (sent by `end_stream`) is waited on until
//!   acknowledged ([`STOP_ACK_WAIT`]), then the writer and the participant
//!   are deleted (the participant says goodbye: the receivers unmatch at
//!   once). The deletion joins rustdds's threads; it is waited on for
//!   [`CLOSE_WAIT`] at most, so a teardown that hangs cannot keep a
//!   stopped run from ending (it is left to the process's exit, and the
//!   stop says so).

pub mod messages;
pub mod pose;
pub mod qos;

use std::time::{Duration, Instant};

use nalgebra::Isometry3;
use rustdds::no_key::{DataReader, DataWriter};
use rustdds::{
    CDRDeserializerAdapter, CDRSerializerAdapter, DataWriterStatus, DomainParticipant,
    DomainParticipantBuilder, DomainParticipantStatusEvent, LostReason, StatusEvented, TopicKind,
};

use crate::arm::settings::Ros2Settings;
use crate::arm::{Arm, ArmError, ArmState, ThreadRef};
use crate::control::motion::stream::ArmCommand;
use messages::{CommandMessage, PoseStamped};

/// How long `stop` waits for the receivers to acknowledge the last (zero)
/// command before deleting the writer. The zero has gone out already;
/// this only confirms it, so it may be generous: the writer asks for
/// acknowledgements every 100 ms, and a receiver on a loaded machine
/// answers late.
pub const STOP_ACK_WAIT: Duration = Duration::from_millis(500);

/// How long `stop` waits for rustdds to delete the writer, the reader and
/// the participant (which joins its discovery and event-loop threads).
/// The zero command has gone out and been waited on by then: a stop that
/// was asked for must end even if the library's teardown hangs.
pub const CLOSE_WAIT: Duration = Duration::from_secs(2);

/// The kernel's name (15 bytes of the thread's name) of a participant's
/// event loop, "RustDDS Participant N event loop".
const EVENT_LOOP_COMM: &str = "RustDDS Partici";

/// The task ids of this process's threads named `comm`.
fn tasks_named(comm: &str) -> Vec<libc::pid_t> {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    tasks
        .flatten()
        .filter(|task| {
            std::fs::read_to_string(task.path().join("comm")).is_ok_and(|c| c.trim_end() == comm)
        })
        .filter_map(|task| task.file_name().to_str()?.parse().ok())
        .collect()
}

/// How often `connect` looks again while it waits.
const CONNECT_POLL: Duration = Duration::from_millis(2);

type CommandWriter = DataWriter<CommandMessage, CDRSerializerAdapter<CommandMessage>>;
type PoseReader = DataReader<PoseStamped, CDRDeserializerAdapter<PoseStamped>>;

/// The DDS entities of a connected arm. Fields drop in order: the writer
/// and the reader before the participant that owns them.
struct Link {
    writer: CommandWriter,
    pose_reader: Option<PoseReader>,
    participant: DomainParticipant,
    /// The participant's event loop's task ids: it sends what the writer
    /// queues, so a command waits on it.
    event_loop: Vec<libc::pid_t>,
    /// Matched subscribers now, as the writer's status last said.
    matched: i32,
    /// Why the last remote participant or reader went away (for the
    /// error), as discovery said.
    last_loss: Option<String>,
}

/// A ROS 2 command topic (see the module docs).
pub struct Ros2Arm {
    topic: String,
    settings: Ros2Settings,
    connect_timeout: Duration,
    link: Option<Link>,
    /// The last command sent (the state's `executing`).
    last: ArmCommand,
    /// The newest measured pose and whether `feedback` has given it yet.
    pose: Option<(Isometry3<f64>, bool)>,
    /// Poses refused (non-finite, not a unit quaternion).
    refused_poses: u64,
    /// Once the link is known lost, why (every later call says the same).
    lost: Option<String>,
}

impl Ros2Arm {
    /// An arm for `topic` (as `--arm ros2:TOPIC` gave it), not connected.
    pub fn new(topic: &str, settings: &Ros2Settings, connect_timeout_ms: u32) -> Ros2Arm {
        Ros2Arm {
            topic: topic.to_string(),
            settings: settings.clone(),
            connect_timeout: Duration::from_millis(connect_timeout_ms.into()),
            link: None,
            last: ArmCommand::default(),
            pose: None,
            refused_poses: 0,
            lost: None,
        }
    }

    /// What the command side is, for errors: topic, DDS names, domain.
    fn what(&self) -> String {
        format!(
            "ROS 2 topic {} ({}; DDS topic {}, type {}) on domain {}",
            self.topic,
            messages::ros_name(self.settings.message),
            messages::dds_topic_name(&self.topic),
            messages::dds_type_name(self.settings.message),
            self.settings.domain_id
        )
    }

    /// Creates the participant, the writer and the pose reader.
    fn open(&self) -> Result<Link, String> {
        let before = tasks_named(EVENT_LOOP_COMM);
        let participant = DomainParticipantBuilder::new(self.settings.domain_id)
            .build()
            .map_err(|e| format!("cannot start a DDS participant: {e}"))?;
        let event_loop = tasks_named(EVENT_LOOP_COMM)
            .into_iter()
            .filter(|tid| !before.contains(tid))
            .collect();
        let topic = participant
            .create_topic(
                messages::dds_topic_name(&self.topic),
                messages::dds_type_name(self.settings.message).to_string(),
                &qos::commands(),
                TopicKind::NoKey,
            )
            .map_err(|e| format!("cannot create the command topic: {e}"))?;
        let publisher = participant
            .create_publisher(&qos::commands())
            .map_err(|e| format!("cannot create a publisher: {e}"))?;
        let writer = publisher
            .create_datawriter_no_key::<CommandMessage, CDRSerializerAdapter<CommandMessage>>(
                &topic,
                Some(qos::commands()),
            )
            .map_err(|e| format!("cannot create the command writer: {e}"))?;
        let pose_reader = if self.settings.pose_topic.is_empty() {
            None
        } else {
            let topic = participant
                .create_topic(
                    messages::dds_topic_name(&self.settings.pose_topic),
                    messages::POSE_STAMPED_TYPE.to_string(),
                    &qos::pose(),
                    TopicKind::NoKey,
                )
                .map_err(|e| format!("cannot create the pose topic: {e}"))?;
            let subscriber = participant
                .create_subscriber(&qos::pose())
                .map_err(|e| format!("cannot create a subscriber: {e}"))?;
            Some(
                subscriber
                    .create_datareader_no_key::<PoseStamped, CDRDeserializerAdapter<PoseStamped>>(
                        &topic,
                        Some(qos::pose()),
                    )
                    .map_err(|e| format!("cannot create the pose reader: {e}"))?,
            )
        };
        Ok(Link {
            writer,
            pose_reader,
            participant,
            event_loop,
            matched: 0,
            last_loss: None,
        })
    }

    /// Deletes the DDS entities without a stop (a failed connect, a drop),
    /// waiting at most [`CLOSE_WAIT`] (the caller's own error, if any, says
    /// what went wrong).
    fn close_link(&mut self) {
        if let Some(link) = self.link.take() {
            drop_within(link, CLOSE_WAIT);
        }
    }

    /// Takes every pose waiting; keeps the newest good one.
    fn take_poses(&mut self) {
        let Some(link) = self.link.as_mut() else {
            return;
        };
        let Some(reader) = link.pose_reader.as_mut() else {
            return;
        };
        let mut newest = None;
        // A sample that does not decode is an error item: skip it.
        for _ in 0..1000 {
            match reader.take_next_sample() {
                Ok(Some(sample)) => match pose::isometry(sample.value()) {
                    Ok(pose) => newest = Some(pose),
                    Err(_) => self.refused_poses += 1,
                },
                Ok(None) => break,
                Err(_) => self.refused_poses += 1,
            }
        }
        if let Some(pose) = newest {
            self.pose = Some((pose, false));
        }
    }

    /// Reads the writer's and the participant's news; returns the link's
    /// loss, if it is lost.
    fn poll_link(&mut self) -> Option<String> {
        if self.lost.is_some() {
            return self.lost.clone();
        }
        let link = self.link.as_mut()?;
        let listener = link.participant.status_listener();
        while let Some(event) = listener.try_recv_status() {
            match event {
                DomainParticipantStatusEvent::ParticipantLost { reason, .. } => {
                    link.last_loss = Some(describe_loss("its participant", &reason));
                }
                DomainParticipantStatusEvent::ReaderLost { reason, .. } => {
                    link.last_loss = Some(describe_loss("its reader", &reason));
                }
                _ => {}
            }
        }
        let before = link.matched;
        while let Some(status) = link.writer.try_recv_status() {
            if let DataWriterStatus::PublicationMatched { current, .. } = status {
                link.matched = current.count();
            }
        }
        if before > 0 && link.matched == 0 {
            let why = link
                .last_loss
                .clone()
                .unwrap_or_else(|| "it unmatched".to_string());
            let lost = format!(
                "the receiver of {} is gone ({why}); no subscriber is left",
                self.what()
            );
            self.lost = Some(lost.clone());
            return Some(lost);
        }
        None
    }

    /// Writes one command without blocking.
    fn write(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        let message = messages::command_message(
            self.settings.message,
            command,
            &self.settings.frame_id,
            messages::Time::now(),
        );
        let Some(link) = self.link.as_ref() else {
            return Err(ArmError::Unavailable {
                detail: format!("{}: not connected", self.what()),
            });
        };
        match link.writer.write(message, None) {
            Ok(()) => Ok(()),
            Err(rustdds::dds::result::WriteError::WouldBlock { .. }) => {
                let lost = format!(
                    "the receiver of {} has not acknowledged the last {} commands ({} ms): it stopped answering (killed, frozen or cut off)",
                    self.what(),
                    qos::ACK_WINDOW,
                    qos::ACK_WINDOW * 10
                );
                self.lost = Some(lost.clone());
                Err(ArmError::Disconnected { detail: lost })
            }
            Err(e) => Err(ArmError::Disconnected {
                detail: format!("{}: cannot send: {e}", self.what()),
            }),
        }
    }
}

/// Says why discovery dropped a remote entity.
fn describe_loss(what: &str, reason: &LostReason) -> String {
    match reason {
        LostReason::Disposed => format!("{what} said goodbye"),
        LostReason::Timeout { lease, elapsed } => format!(
            "{what}'s lease ran out: silent for {:.1} s, lease {:.1} s",
            elapsed.to_std().as_secs_f64(),
            lease.to_std().as_secs_f64()
        ),
    }
}

impl Arm for Ros2Arm {
    fn describe(&self) -> String {
        format!("ros2:{}", self.topic)
    }

    fn connect(&mut self) -> Result<(), ArmError> {
        let start = Instant::now();
        let deadline = start + self.connect_timeout;
        let unavailable = |detail: String| ArmError::Unavailable { detail };
        let link = self
            .open()
            .map_err(|e| unavailable(format!("{}: {e}", self.what())))?;
        self.link = Some(link);
        // 1. A subscriber matched (it asked for what we offer).
        loop {
            self.poll_link();
            if self.link.as_ref().is_some_and(|l| l.matched > 0) {
                break;
            }
            if Instant::now() >= deadline {
                self.close_link();
                return Err(unavailable(format!(
                    "no subscriber matched {} within {} ms: is the driver / servo node running, on this topic and with this message type? Is ROS_DOMAIN_ID (here [arm.ros2] domain_id = {}) the same? A subscriber asking for transient-local durability does not match this volatile stream.",
                    self.what(),
                    self.connect_timeout.as_millis(),
                    self.settings.domain_id
                )));
            }
            std::thread::sleep(CONNECT_POLL);
        }
        // 2. It acknowledged a zero command: it has matched us too, so
        // nothing sent from here on is dropped as coming from an unknown
        // writer (the loss seen when publishing right after the match).
        self.write(&ArmCommand::default())?;
        let acknowledged = loop {
            let link = self.link.as_ref().ok_or_else(|| unavailable(self.what()))?;
            match link.writer.wait_for_acknowledgments(CONNECT_POLL) {
                Ok(true) => break true,
                Ok(false) if Instant::now() < deadline => {}
                _ => break false,
            }
        };
        if !acknowledged {
            self.close_link();
            return Err(unavailable(format!(
                "a subscriber matched {} but did not acknowledge a command within {} ms: is it reliable, and is the network between us open both ways (a firewall on UDP)?",
                self.what(),
                self.connect_timeout.as_millis()
            )));
        }
        // 3. The first measured pose.
        if !self.settings.pose_topic.is_empty() {
            loop {
                self.take_poses();
                if self.pose.is_some() {
                    break;
                }
                if Instant::now() >= deadline {
                    let refused = self.refused_poses;
                    self.close_link();
                    return Err(unavailable(format!(
                        "no pose on ROS 2 topic {} (geometry_msgs/msg/PoseStamped; DDS topic {}, type {}) on domain {} within {} ms{}: is the driver publishing the tool pose there ([arm.ros2] pose_topic)?",
                        self.settings.pose_topic,
                        messages::dds_topic_name(&self.settings.pose_topic),
                        messages::POSE_STAMPED_TYPE,
                        self.settings.domain_id,
                        self.connect_timeout.as_millis(),
                        if refused > 0 {
                            format!(" ({refused} refused: non-finite or not a unit quaternion)")
                        } else {
                            String::new()
                        }
                    )));
                }
                std::thread::sleep(CONNECT_POLL);
            }
        }
        Ok(())
    }

    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        if let Some(lost) = self.poll_link() {
            return Err(ArmError::Disconnected { detail: lost });
        }
        self.write(command)?;
        self.last = *command;
        Ok(())
    }

    fn feedback(&mut self) -> Option<ArmState> {
        self.take_poses();
        match self.pose.as_mut() {
            Some((pose, given)) if !*given => {
                *given = true;
                Some(ArmState {
                    pose: *pose,
                    fingers: None,
                    executing: self.last,
                })
            }
            _ => None,
        }
    }

    fn measures_pose(&self) -> bool {
        !self.settings.pose_topic.is_empty()
    }

    fn check_link(&mut self) -> Result<(), ArmError> {
        match self.poll_link() {
            Some(lost) => Err(ArmError::Disconnected { detail: lost }),
            None => Ok(()),
        }
    }

    /// The participant's event loop, which sends each command the writer
    /// queues.
    fn threads(&self) -> Vec<(String, ThreadRef)> {
        self.link
            .iter()
            .flat_map(|link| &link.event_loop)
            .map(|&tid| ("dds-event-loop".to_string(), ThreadRef::Task(tid)))
            .collect()
    }

    fn stop(&mut self) -> Result<(), ArmError> {
        let Some(link) = self.link.take() else {
            return Ok(());
        };
        // The zero command `end_stream` just sent: acknowledged by every
        // matched reliable receiver, or the wait runs out. A receiver
        // already gone acknowledges nothing: no wait for it.
        let acknowledged = if self.lost.is_some() || link.matched == 0 {
            true
        } else {
            matches!(
                link.writer.wait_for_acknowledgments(STOP_ACK_WAIT),
                Ok(true)
            )
        };
        // Writer, reader, then the participant (its goodbye).
        let closed = drop_within(link, CLOSE_WAIT);
        let mut problems = Vec::new();
        if !acknowledged {
            problems.push(format!(
                "the zero command on {} was not acknowledged within {} ms",
                self.what(),
                STOP_ACK_WAIT.as_millis()
            ));
        }
        if !closed {
            problems.push(format!(
                "the DDS participant of {} did not close within {} ms (rustdds hung deleting it); it is left to the process's exit, and receivers see it go when its lease runs out",
                self.what(),
                CLOSE_WAIT.as_millis()
            ));
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(ArmError::Disconnected {
                detail: problems.join("; "),
            })
        }
    }
}

/// Dropped without `stop` (a connect that failed part-way, a panic
/// unwinding): the DDS entities are deleted within [`CLOSE_WAIT`] all the
/// same.
impl Drop for Ros2Arm {
    fn drop(&mut self) {
        self.close_link();
    }
}

/// Drops `value` on a thread of its own and waits up to `limit` for the
/// drop to finish: whether it did. A drop that hangs is left running (the
/// process's exit ends it). If no thread can be started, the value is
/// dropped here, without a bound.
fn drop_within<T: Send + 'static>(value: T, limit: Duration) -> bool {
    let (done_tx, done_rx) = std::sync::mpsc::channel();
    let closing = std::thread::Builder::new()
        .name("dds-close".into())
        .spawn(move || {
            drop(value);
            let _ = done_tx.send(());
        });
    match closing {
        // A drop that panicked ended its thread too: not hanging.
        Ok(_) => !matches!(
            done_rx.recv_timeout(limit),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout)
        ),
        Err(_) => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;

    /// A value whose drop blocks until the test releases it.
    struct HangsOnDrop(mpsc::Receiver<()>);

    impl Drop for HangsOnDrop {
        fn drop(&mut self) {
            let _ = self.0.recv();
        }
    }

    #[test]
    fn a_teardown_that_hangs_is_left_behind_and_a_quick_one_is_waited_for() {
        let (release, held) = mpsc::channel();
        assert!(!drop_within(HangsOnDrop(held), Duration::from_millis(50)));
        // Let the left-behind thread end.
        release.send(()).unwrap();

        let (dropped_tx, dropped) = mpsc::channel::<()>();
        assert!(drop_within(dropped_tx, Duration::from_secs(60)));
        // The value was dropped: its channel is closed.
        assert!(dropped.recv().is_err());
    }
}
