//! Scripted input: a small text format that plays the game without a window, through the same
//! [`Input`] resource and systems a player at the keyboard would drive.
//!
//! One command per line; `#` starts a comment; blank lines are ignored; words are separated by
//! spaces and case-insensitive.
//!
//! | command | effect |
//! | --- | --- |
//! | `wait SECONDS` | nothing happens for that long |
//! | `walk forward\|back\|left\|right SECONDS` | holds W, S, A or D that long |
//! | `hold KEY SECONDS` | holds any key that long (`hold Shift 1`) |
//! | `turn DEGREES` | turns right (negative: left) by mouse motion, in one frame |
//! | `look DEGREES` | looks up (negative: down) by mouse motion, in one frame |
//! | `shoot [U V]` | a left click with the crosshair at normalised screen coordinates (U, V) in [0, 1]², (0, 0) top-left; the screen centre without coordinates |
//! | `light` | taps L (drops a light) |
//! | `aim` | turns the view onto the walking character's body (`crate::character::Walker`), in one frame; nothing without one |
//! | `key KEY` | taps a key for one frame (`key E`, `key 3`) |
//!
//! Keys are named as [`Key::name`] spells them. Timed commands last as many frames as their
//! duration covers at the frame time [`Time::delta`] (with a fixed step of 1/60 s,
//! `walk forward 2` holds W for exactly 120 frames); every other command takes one frame, so two
//! `shoot`s are two separate clicks. Turning and looking go through the player's mouse
//! sensitivity, so `turn 90` turns exactly 90°.
//!
//! ```
//! use sandbox::game::Script;
//!
//! let script = Script::parse("walk forward 1.5\nturn -30  # left\nshoot 0.5 0.6\n").unwrap();
//! assert_eq!(script.len(), 3);
//! let error = Script::parse("wait 1\njump 2\n").unwrap_err();
//! assert_eq!(error.line, 2);
//! assert!(error.to_string().starts_with("line 2: unknown command `jump`"));
//! ```

use std::fmt;
use std::path::Path;

use anyhow::Context;
use bevy_ecs::query::With;
use bevy_ecs::resource::Resource;
use bevy_ecs::system::{Query, Res, ResMut};
use engine::input::{Input, Key, MouseButton};
use engine::time::Time;
use engine::transform::{GlobalTransform, Transform};
use glam::{Vec2, Vec3};

use super::player::{Player, PlayerController};
use super::shooting::Crosshair;

/// The longest duration a timed command may have, in seconds (an hour).
pub const MAX_COMMAND_SECONDS: f32 = 3600.0;

/// Durations left below this count as done, absorbing rounding in sums of frame times.
const TIME_EPSILON: f32 = 1e-4;

/// A direction to walk in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkDirection {
    /// Forward (W).
    Forward,
    /// Backward (S).
    Back,
    /// Strafe left (A).
    Left,
    /// Strafe right (D).
    Right,
}

impl WalkDirection {
    /// The key that walks this way.
    pub fn key(self) -> Key {
        match self {
            WalkDirection::Forward => Key::W,
            WalkDirection::Back => Key::S,
            WalkDirection::Left => Key::A,
            WalkDirection::Right => Key::D,
        }
    }
}

/// One scripted command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Do nothing for the given seconds.
    Wait(f32),
    /// Hold a key for the given seconds (`walk` and `hold`).
    Hold(Key, f32),
    /// Turn right by the given degrees (negative: left).
    Turn(f32),
    /// Look up by the given degrees (negative: down).
    Look(f32),
    /// Left click with the crosshair at the given normalised screen point.
    Shoot(Vec2),
    /// Tap a key for one frame (`light` is `Tap(Key::L)`).
    Tap(Key),
    /// Turn and look onto the walking character.
    Aim,
}

impl Command {
    /// The command's duration in seconds if it is timed.
    pub fn seconds(&self) -> Option<f32> {
        match *self {
            Command::Wait(s) | Command::Hold(_, s) => Some(s),
            _ => None,
        }
    }
}

/// A script line that could not be parsed: its 1-based line number and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScriptError {
    /// The line, counting from 1.
    pub line: usize,
    /// The problem.
    pub message: String,
}

impl fmt::Display for ScriptError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for ScriptError {}

/// A parsed script: commands with the lines they came from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    commands: Vec<(usize, Command)>,
}

impl Script {
    /// Parses the text format of the module docs; the first bad line is an error.
    pub fn parse(text: &str) -> Result<Script, ScriptError> {
        let mut commands = Vec::new();
        for (index, raw) in text.lines().enumerate() {
            let line = index + 1;
            let content = raw.split('#').next().unwrap_or("").trim();
            if content.is_empty() {
                continue;
            }
            let command = parse_command(content).map_err(|message| ScriptError { line, message })?;
            commands.push((line, command));
        }
        Ok(Script { commands })
    }

    /// Reads and parses a script file; errors name the file and, for parse errors, the line.
    pub fn load(path: &Path) -> anyhow::Result<Script> {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading script {}", path.display()))?;
        Script::parse(&text).with_context(|| format!("in script {}", path.display()))
    }

    /// A script of the given commands (each reported as its own line).
    pub fn from_commands(commands: impl IntoIterator<Item = Command>) -> Script {
        Script { commands: commands.into_iter().enumerate().map(|(i, c)| (i + 1, c)).collect() }
    }

    /// The commands with their line numbers, in order.
    pub fn commands(&self) -> &[(usize, Command)] {
        &self.commands
    }

    /// Number of commands.
    pub fn len(&self) -> usize {
        self.commands.len()
    }

    /// Whether there are no commands.
    pub fn is_empty(&self) -> bool {
        self.commands.is_empty()
    }

    /// Total seconds of the timed commands.
    pub fn timed_seconds(&self) -> f64 {
        self.commands.iter().filter_map(|(_, c)| c.seconds()).map(f64::from).sum()
    }

    /// How many frames the script takes at a fixed frame time of `dt` seconds (> 0), or `None`
    /// for a non-positive or non-finite `dt`.
    pub fn frames_at(&self, dt: f32) -> Option<u64> {
        if !(dt > 0.0 && dt.is_finite()) {
            return None;
        }
        Some(
            self.commands
                .iter()
                .map(|(_, c)| match c.seconds() {
                    Some(s) if s <= TIME_EPSILON => 0,
                    Some(s) => ((s - TIME_EPSILON) / dt).ceil().max(1.0) as u64,
                    None => 1,
                })
                .sum(),
        )
    }
}

/// Parses one non-empty, comment-free line.
fn parse_command(content: &str) -> Result<Command, String> {
    let words: Vec<&str> = content.split_whitespace().collect();
    let name = words[0].to_ascii_lowercase();
    let args = &words[1..];
    let expect = |count: usize, usage: &str| {
        if args.len() == count {
            Ok(())
        } else {
            Err(format!("`{name}` takes {count} argument{} ({usage}), got {}", if count == 1 { "" } else { "s" }, args.len()))
        }
    };
    match name.as_str() {
        "wait" => {
            expect(1, "wait SECONDS")?;
            Ok(Command::Wait(seconds(args[0])?))
        }
        "walk" => {
            expect(2, "walk forward|back|left|right SECONDS")?;
            let direction = match args[0].to_ascii_lowercase().as_str() {
                "forward" | "forwards" => WalkDirection::Forward,
                "back" | "backward" | "backwards" => WalkDirection::Back,
                "left" => WalkDirection::Left,
                "right" => WalkDirection::Right,
                other => {
                    return Err(format!("unknown walking direction `{other}` (forward, back, left, right)"));
                }
            };
            Ok(Command::Hold(direction.key(), seconds(args[1])?))
        }
        "hold" => {
            expect(2, "hold KEY SECONDS")?;
            Ok(Command::Hold(key(args[0])?, seconds(args[1])?))
        }
        "turn" => {
            expect(1, "turn DEGREES")?;
            Ok(Command::Turn(number(args[0], "degrees")?))
        }
        "look" => {
            expect(1, "look DEGREES")?;
            Ok(Command::Look(number(args[0], "degrees")?))
        }
        "shoot" => match args.len() {
            0 => Ok(Command::Shoot(Vec2::splat(0.5))),
            2 => {
                let point = Vec2::new(number(args[0], "U")?, number(args[1], "V")?);
                if !(0.0..=1.0).contains(&point.x) || !(0.0..=1.0).contains(&point.y) {
                    return Err(format!("screen point ({}, {}) is outside [0, 1]²", point.x, point.y));
                }
                Ok(Command::Shoot(point))
            }
            n => Err(format!("`shoot` takes no arguments or 2 (shoot U V), got {n}")),
        },
        "light" => {
            expect(0, "light")?;
            Ok(Command::Tap(Key::L))
        }
        "aim" => {
            expect(0, "aim")?;
            Ok(Command::Aim)
        }
        "key" => {
            expect(1, "key KEY")?;
            Ok(Command::Tap(key(args[0])?))
        }
        _ => Err(format!("unknown command `{}` (wait, walk, hold, turn, look, shoot, light, key)", words[0])),
    }
}

fn number(word: &str, what: &str) -> Result<f32, String> {
    let value: f32 = word.parse().map_err(|_| format!("{what} `{word}` is not a number"))?;
    if value.is_finite() { Ok(value) } else { Err(format!("{what} `{word}` is not finite")) }
}

fn seconds(word: &str) -> Result<f32, String> {
    let value = number(word, "seconds")?;
    if !(0.0..=MAX_COMMAND_SECONDS).contains(&value) {
        return Err(format!("duration {value} s is outside 0..={MAX_COMMAND_SECONDS} s"));
    }
    Ok(value)
}

fn key(word: &str) -> Result<Key, String> {
    Key::from_name(word).ok_or_else(|| {
        let names: Vec<&str> = Key::ALL.iter().map(|k| k.name()).collect();
        format!("unknown key `{word}` ({})", names.join(", "))
    })
}

/// Plays a [`Script`] into [`Input`], one step per frame, from [`play_script`].
#[derive(Resource, Clone, Debug)]
pub struct ScriptPlayer {
    script: Script,
    /// The command playing now.
    index: usize,
    /// Seconds left of the current timed command, once it started.
    remaining: Option<f32>,
    /// A key or the left button tapped last frame, released at the start of this one.
    tapped: Option<Tap>,
    /// The crosshair to restore after a shot at another screen point.
    restore_crosshair: Option<Vec2>,
    /// The line of the command that acted in the last step.
    played_line: Option<usize>,
    frames: u64,
    /// What `aim` turns and looks by this frame, in degrees ([`ScriptPlayer::set_aim`]).
    aim: Option<Vec2>,
}

#[derive(Clone, Copy, Debug)]
enum Tap {
    Key(Key),
    Click,
}

impl ScriptPlayer {
    /// A player at the start of `script`.
    pub fn new(script: Script) -> Self {
        Self { script, index: 0, remaining: None, tapped: None, restore_crosshair: None, played_line: None, frames: 0, aim: None }
    }

    /// Sets what an `aim` command would turn (right) and look (up) by this frame, in degrees:
    /// the way from the view to the character (`None`: there is none to aim at).
    pub fn set_aim(&mut self, turn_look: Option<Vec2>) {
        self.aim = turn_look;
    }

    /// Whether every command has had all its frames (after [`Script::frames_at`] steps at a
    /// fixed frame time). Keys still down from the last command are released on the next step.
    pub fn is_finished(&self) -> bool {
        let last_timed_done = self.index + 1 == self.script.len() && self.remaining.is_some_and(|left| left <= TIME_EPSILON);
        self.index >= self.script.len() || last_timed_done
    }

    /// The line of the command that plays next (or goes on playing), or `None` when finished.
    pub fn current_line(&self) -> Option<usize> {
        if self.is_finished() {
            return None;
        }
        self.script.commands.get(self.index).map(|&(line, _)| line)
    }

    /// The line of the command that acted in the last step (held its key, waited, clicked,
    /// turned...), or `None` when that step did nothing.
    pub fn played_line(&self) -> Option<usize> {
        self.played_line
    }

    /// Frames stepped so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The script being played.
    pub fn script(&self) -> &Script {
        &self.script
    }

    /// Plays one frame: starts the input frame ([`Input::begin_frame`]), releases last frame's
    /// taps, and applies the current command for a frame of `dt` seconds. `sensitivity` is the
    /// player's mouse sensitivity in radians per pixel, which turns degrees into mouse motion.
    pub fn step(&mut self, dt: f32, sensitivity: f32, input: &mut Input, crosshair: &mut Crosshair) {
        input.begin_frame();
        self.frames += 1;
        self.played_line = None;
        match self.tapped.take() {
            Some(Tap::Key(key)) => input.release(key),
            Some(Tap::Click) => input.release_button(MouseButton::Left),
            None => {}
        }
        if let Some(centre) = self.restore_crosshair.take() {
            crosshair.0 = centre;
        }
        let pixels_per_degree = if sensitivity.is_finite() && sensitivity > 0.0 { 1f32.to_radians() / sensitivity } else { 0.0 };
        while let Some(&(line, command)) = self.script.commands.get(self.index) {
            match command {
                Command::Wait(seconds) | Command::Hold(_, seconds) => {
                    let key = match command {
                        Command::Hold(key, _) => Some(key),
                        _ => None,
                    };
                    let remaining = match self.remaining {
                        None if seconds <= TIME_EPSILON => {
                            self.index += 1;
                            continue;
                        }
                        None => {
                            if let Some(key) = key {
                                input.press(key);
                            }
                            seconds
                        }
                        Some(left) if left <= TIME_EPSILON => {
                            // Done last frame: release and go on with the next command now.
                            if let Some(key) = key {
                                input.release(key);
                            }
                            self.remaining = None;
                            self.index += 1;
                            continue;
                        }
                        Some(left) => left,
                    };
                    self.remaining = Some(remaining - dt.max(0.0));
                }
                Command::Turn(degrees) => {
                    input.add_mouse_motion(Vec2::new(degrees * pixels_per_degree, 0.0));
                    self.index += 1;
                }
                Command::Look(degrees) => {
                    input.add_mouse_motion(Vec2::new(0.0, -degrees * pixels_per_degree));
                    self.index += 1;
                }
                Command::Shoot(point) => {
                    self.restore_crosshair = Some(crosshair.0);
                    crosshair.0 = point;
                    input.press_button(MouseButton::Left);
                    self.tapped = Some(Tap::Click);
                    self.index += 1;
                }
                Command::Tap(key) => {
                    input.press(key);
                    self.tapped = Some(Tap::Key(key));
                    self.index += 1;
                }
                Command::Aim => {
                    if let Some(aim) = self.aim {
                        input.add_mouse_motion(Vec2::new(aim.x * pixels_per_degree, -aim.y * pixels_per_degree));
                    }
                    self.index += 1;
                }
            }
            self.played_line = Some(line);
            return;
        }
    }
}

/// Steps the [`ScriptPlayer`] resource by [`Time::delta`] (in `PreUpdate`; the game plugin adds
/// it, running while the resource exists). It is the frame's input feeder: it calls
/// [`Input::begin_frame`] itself.
pub fn play_script(
    time: Res<Time>,
    mut player: ResMut<ScriptPlayer>,
    mut input: ResMut<Input>,
    mut crosshair: ResMut<Crosshair>,
    controllers: Query<(&PlayerController, &Transform), With<Player>>,
    walkers: Query<&GlobalTransform, With<crate::character::Walker>>,
) {
    let controller = controllers.single().ok();
    let sensitivity = controller.map_or(PlayerController::default().mouse_sensitivity, |(c, _)| c.mouse_sensitivity);
    // `aim`: from the view to the middle of the nearest walker's body (its origin is at its feet).
    let aim = controller.and_then(|(c, eye)| {
        let eye = eye.translation;
        let target =
            walkers.iter().map(|w| w.translation() + Vec3::Y * AIM_HEIGHT).min_by(|a, b| a.distance(eye).total_cmp(&b.distance(eye)))?;
        let d = (target - eye).try_normalize()?;
        let yaw = (-d.x).atan2(-d.z);
        let turn = ((c.yaw - yaw + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI).to_degrees();
        let look = (d.y.clamp(-1.0, 1.0).asin() - c.pitch).to_degrees();
        Some(Vec2::new(turn, look))
    });
    player.set_aim(aim);
    player.step(time.delta_secs(), sensitivity, &mut input, &mut crosshair);
}

/// Height above a walker's origin that `aim` aims at, in metres (the middle of the fox's body).
const AIM_HEIGHT: f32 = 0.4;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_command() {
        let script = Script::parse(
            "# a walk\n\nwait 0.5\nWALK Forward 2\nwalk back 1 # comment\nhold shift 0.25\nturn -30\nlook 10\nshoot\nshoot 0.25 1\nlight\nkey esc\n",
        )
        .unwrap();
        let commands: Vec<Command> = script.commands().iter().map(|&(_, c)| c).collect();
        assert_eq!(
            commands,
            [
                Command::Wait(0.5),
                Command::Hold(Key::W, 2.0),
                Command::Hold(Key::S, 1.0),
                Command::Hold(Key::Shift, 0.25),
                Command::Turn(-30.0),
                Command::Look(10.0),
                Command::Shoot(Vec2::splat(0.5)),
                Command::Shoot(Vec2::new(0.25, 1.0)),
                Command::Tap(Key::L),
                Command::Tap(Key::Escape),
            ]
        );
        assert_eq!(script.commands()[0].0, 3, "line numbers skip comments and blanks");
        assert!((script.timed_seconds() - 3.75).abs() < 1e-9);
        assert_eq!(script.frames_at(0.25), Some(2 + 8 + 4 + 1 + 6));
    }

    #[test]
    fn errors_name_the_line_and_the_problem() {
        let cases = [
            ("wait", 1, "takes 1 argument"),
            ("wait 1\nwait x", 2, "not a number"),
            ("walk sideways 1", 1, "unknown walking direction `sideways`"),
            ("\n\nwait -1", 3, "outside"),
            ("wait inf", 1, "not finite"),
            ("shoot 1.5 0.5", 1, "outside [0, 1]"),
            ("shoot 0.5", 1, "no arguments or 2"),
            ("key Q", 1, "unknown key `Q`"),
            ("light now", 1, "takes 0 arguments"),
            ("fly 3", 1, "unknown command `fly`"),
        ];
        for (text, line, message) in cases {
            let error = Script::parse(text).unwrap_err();
            assert_eq!(error.line, line, "{text:?}: {error}");
            assert!(error.message.contains(message), "{text:?}: {error}");
            assert!(error.to_string().starts_with(&format!("line {line}: ")));
        }
    }

    #[test]
    fn timed_commands_hold_for_whole_frames_and_taps_for_one() {
        let script = Script::parse("walk forward 0.5\nshoot 0.2 0.3\nkey E\nturn 90\n").unwrap();
        let dt = 0.125;
        let mut player = ScriptPlayer::new(script.clone());
        let (mut input, mut crosshair) = (Input::default(), Crosshair::default());
        let mut w_frames = 0;
        let mut log = Vec::new();
        while !player.is_finished() {
            player.step(dt, 0.01, &mut input, &mut crosshair);
            w_frames += input.pressed(Key::W) as u32;
            log.push((input.button_just_pressed(MouseButton::Left), crosshair.0, input.just_pressed(Key::E), input.mouse_motion.x));
        }
        assert_eq!(w_frames, 4, "0.5 s at 1/8 s per frame");
        assert_eq!(player.frames(), script.frames_at(dt).unwrap());
        // Frame 5 releases W and clicks at (0.2, 0.3); frame 6 taps E with the crosshair back.
        assert_eq!(log[4], (true, Vec2::new(0.2, 0.3), false, 0.0));
        assert_eq!(log[5], (false, Vec2::splat(0.5), true, 0.0));
        assert!(!input.pressed(Key::W));
        // 90° at 0.01 rad per pixel.
        assert!((log[6].3 * 0.01 - 90f32.to_radians()).abs() < 1e-5);
        player.step(dt, 0.01, &mut input, &mut crosshair);
        assert!(!input.button_pressed(MouseButton::Left) && !input.pressed(Key::E));
    }
}
