//! Keyboard and mouse state for gameplay systems: the [`Input`] resource.
//!
//! `Input` knows nothing about windows: whoever owns the events (the window layer, a scripted
//! player in headless runs, a test) writes into it, and gameplay systems in `Update` read it.
//!
//! # The feeding contract
//!
//! Once per frame, **before** writing that frame's events, the feeder calls
//! [`Input::begin_frame`], which clears the per-frame parts (keys and buttons pressed or released
//! this frame, mouse motion) and keeps what is held. It then reports what happened with
//! [`Input::press`]/[`Input::release`], [`Input::press_button`]/[`Input::release_button`],
//! [`Input::add_mouse_motion`] and [`Input::set_cursor`]. Everything must be written before
//! `Update` runs:
//!
//! * a window loop (winit) calls `begin_frame` right after `App::update` returns, since the
//!   events it receives next belong to the next frame, and feeds them as they arrive;
//! * a system feeding input from inside the app (such as the sandbox's script player) calls
//!   `begin_frame` and writes its events in `PreUpdate`.
//!
//! Only one feeder should call `begin_frame` per frame, or the second would erase the first's
//! presses.
//!
//! ```
//! use engine::input::{Input, Key, MouseButton};
//! use glam::Vec2;
//!
//! let mut input = Input::default();
//! input.begin_frame();
//! input.press(Key::W);
//! input.press_button(MouseButton::Left);
//! input.add_mouse_motion(Vec2::new(4.0, -2.0));
//! assert!(input.pressed(Key::W) && input.just_pressed(Key::W));
//! assert!(input.button_just_pressed(MouseButton::Left));
//!
//! input.begin_frame(); // next frame: still held, no longer "just" pressed, no motion
//! assert!(input.pressed(Key::W) && !input.just_pressed(Key::W));
//! assert_eq!(input.mouse_motion, Vec2::ZERO);
//! ```

use bevy_ecs::resource::Resource;
use glam::Vec2;

use crate::app::{App, Plugin};

/// The keys gameplay reads. Window layers map their own key codes onto these and ignore the
/// rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Key {
    /// W (walk forward).
    W,
    /// A (strafe left).
    A,
    /// S (walk backward).
    S,
    /// D (strafe right).
    D,
    /// The space bar.
    Space,
    /// Either shift key.
    Shift,
    /// E.
    E,
    /// F.
    F,
    /// L.
    L,
    /// Escape.
    Escape,
    /// Tab.
    Tab,
    /// F1.
    F1,
    /// The digit 0 (top row or keypad).
    Digit0,
    /// The digit 1.
    Digit1,
    /// The digit 2.
    Digit2,
    /// The digit 3.
    Digit3,
    /// The digit 4.
    Digit4,
    /// The digit 5.
    Digit5,
    /// The digit 6.
    Digit6,
    /// The digit 7.
    Digit7,
    /// The digit 8.
    Digit8,
    /// The digit 9.
    Digit9,
}

impl Key {
    /// Every key, in declaration order.
    pub const ALL: [Key; 22] = [
        Key::W,
        Key::A,
        Key::S,
        Key::D,
        Key::Space,
        Key::Shift,
        Key::E,
        Key::F,
        Key::L,
        Key::Escape,
        Key::Tab,
        Key::F1,
        Key::Digit0,
        Key::Digit1,
        Key::Digit2,
        Key::Digit3,
        Key::Digit4,
        Key::Digit5,
        Key::Digit6,
        Key::Digit7,
        Key::Digit8,
        Key::Digit9,
    ];

    /// The key's name as scripts and messages spell it: `W`, `Space`, `Shift`, `Escape`, `Tab`,
    /// `F1`, `0`..`9`.
    pub fn name(self) -> &'static str {
        match self {
            Key::W => "W",
            Key::A => "A",
            Key::S => "S",
            Key::D => "D",
            Key::Space => "Space",
            Key::Shift => "Shift",
            Key::E => "E",
            Key::F => "F",
            Key::L => "L",
            Key::Escape => "Escape",
            Key::Tab => "Tab",
            Key::F1 => "F1",
            Key::Digit0 => "0",
            Key::Digit1 => "1",
            Key::Digit2 => "2",
            Key::Digit3 => "3",
            Key::Digit4 => "4",
            Key::Digit5 => "5",
            Key::Digit6 => "6",
            Key::Digit7 => "7",
            Key::Digit8 => "8",
            Key::Digit9 => "9",
        }
    }

    /// The key named `name` (as [`Key::name`] spells it, case-insensitive; `Esc` is accepted
    /// for Escape), or `None`.
    pub fn from_name(name: &str) -> Option<Key> {
        if name.eq_ignore_ascii_case("esc") {
            return Some(Key::Escape);
        }
        Key::ALL.into_iter().find(|key| key.name().eq_ignore_ascii_case(name))
    }

    /// The digit key for `digit` (0..=9), or `None`.
    pub fn digit(digit: u32) -> Option<Key> {
        Key::ALL.get(12 + digit as usize).copied().filter(|_| digit <= 9)
    }

    fn bit(self) -> u32 {
        1 << self as u32
    }
}

/// The mouse buttons gameplay reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MouseButton {
    /// The primary (left) button.
    Left,
    /// The secondary (right) button.
    Right,
    /// The middle button (wheel click).
    Middle,
}

impl MouseButton {
    fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// Keyboard and mouse state of the current frame (see the module docs for who writes it when).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct Input {
    keys_held: u32,
    keys_pressed: u32,
    keys_released: u32,
    buttons_held: u8,
    buttons_pressed: u8,
    buttons_released: u8,
    /// Mouse motion accumulated this frame, in pixels (+X right, +Y down, as windows report
    /// it). Raw device motion, so it keeps coming while the cursor is grabbed.
    pub mouse_motion: Vec2,
    /// The cursor position in pixels from the window's top-left corner, or `None` while the
    /// cursor is outside the window (or there is no window).
    pub cursor: Option<Vec2>,
}

impl Input {
    /// Starts a new frame: forgets what was pressed or released during the previous one and its
    /// mouse motion; held keys and buttons and the cursor position stay.
    pub fn begin_frame(&mut self) {
        self.keys_pressed = 0;
        self.keys_released = 0;
        self.buttons_pressed = 0;
        self.buttons_released = 0;
        self.mouse_motion = Vec2::ZERO;
    }

    /// Reports `key` going down. A key that is already held (keyboard auto-repeat) does not
    /// count as pressed again.
    pub fn press(&mut self, key: Key) {
        if self.keys_held & key.bit() == 0 {
            self.keys_pressed |= key.bit();
        }
        self.keys_held |= key.bit();
    }

    /// Reports `key` going up.
    pub fn release(&mut self, key: Key) {
        if self.keys_held & key.bit() != 0 {
            self.keys_released |= key.bit();
        }
        self.keys_held &= !key.bit();
    }

    /// Whether `key` is held down.
    pub fn pressed(&self, key: Key) -> bool {
        self.keys_held & key.bit() != 0
    }

    /// Whether `key` went down this frame (it may already be up again).
    pub fn just_pressed(&self, key: Key) -> bool {
        self.keys_pressed & key.bit() != 0
    }

    /// Whether `key` went up this frame.
    pub fn just_released(&self, key: Key) -> bool {
        self.keys_released & key.bit() != 0
    }

    /// The keys held down, in [`Key::ALL`] order.
    pub fn held_keys(&self) -> impl Iterator<Item = Key> + '_ {
        Key::ALL.into_iter().filter(|&key| self.pressed(key))
    }

    /// Reports `button` going down.
    pub fn press_button(&mut self, button: MouseButton) {
        if self.buttons_held & button.bit() == 0 {
            self.buttons_pressed |= button.bit();
        }
        self.buttons_held |= button.bit();
    }

    /// Reports `button` going up.
    pub fn release_button(&mut self, button: MouseButton) {
        if self.buttons_held & button.bit() != 0 {
            self.buttons_released |= button.bit();
        }
        self.buttons_held &= !button.bit();
    }

    /// Whether `button` is held down.
    pub fn button_pressed(&self, button: MouseButton) -> bool {
        self.buttons_held & button.bit() != 0
    }

    /// Whether `button` went down this frame.
    pub fn button_just_pressed(&self, button: MouseButton) -> bool {
        self.buttons_pressed & button.bit() != 0
    }

    /// Whether `button` went up this frame.
    pub fn button_just_released(&self, button: MouseButton) -> bool {
        self.buttons_released & button.bit() != 0
    }

    /// Adds mouse motion in pixels; non-finite deltas are ignored.
    pub fn add_mouse_motion(&mut self, delta: Vec2) {
        if delta.is_finite() {
            self.mouse_motion += delta;
        }
    }

    /// Sets the cursor position in pixels (`None`: the cursor left the window). Non-finite
    /// positions count as `None`.
    pub fn set_cursor(&mut self, position: Option<Vec2>) {
        self.cursor = position.filter(|p| p.is_finite());
    }

    /// Releases every key and button (for example when the window loses focus, so that no key
    /// stays stuck down), reporting each as released this frame.
    pub fn release_all(&mut self) {
        self.keys_released |= self.keys_held;
        self.buttons_released |= self.buttons_held;
        self.keys_held = 0;
        self.buttons_held = 0;
    }
}

/// Inserts an empty [`Input`] resource unless the app already has one. It adds no systems: see
/// the module docs for who clears and fills it.
pub struct InputPlugin;

impl Plugin for InputPlugin {
    fn build(&self, app: &mut App) {
        app.world.init_resource::<Input>();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn press_hold_release_across_frames() {
        let mut input = Input::default();
        input.begin_frame();
        input.press(Key::D);
        input.press(Key::D); // auto-repeat
        assert!(input.pressed(Key::D) && input.just_pressed(Key::D));
        assert!(!input.pressed(Key::A) && !input.just_pressed(Key::A));
        input.begin_frame();
        input.press(Key::D); // auto-repeat in a later frame is not a new press
        assert!(input.pressed(Key::D) && !input.just_pressed(Key::D));
        input.release(Key::D);
        assert!(!input.pressed(Key::D) && input.just_released(Key::D));
        input.begin_frame();
        assert!(!input.just_released(Key::D));
        assert_eq!(input.held_keys().count(), 0);
    }

    #[test]
    fn tap_within_one_frame_counts_as_pressed() {
        let mut input = Input::default();
        input.begin_frame();
        input.press_button(MouseButton::Left);
        input.release_button(MouseButton::Left);
        assert!(input.button_just_pressed(MouseButton::Left));
        assert!(input.button_just_released(MouseButton::Left));
        assert!(!input.button_pressed(MouseButton::Left));
        assert!(!input.button_just_pressed(MouseButton::Right));
    }

    #[test]
    fn motion_accumulates_and_clears() {
        let mut input = Input::default();
        input.add_mouse_motion(Vec2::new(1.0, 2.0));
        input.add_mouse_motion(Vec2::new(3.0, -1.0));
        input.add_mouse_motion(Vec2::new(f32::NAN, 0.0));
        assert_eq!(input.mouse_motion, Vec2::new(4.0, 1.0));
        input.set_cursor(Some(Vec2::new(10.0, 20.0)));
        input.begin_frame();
        assert_eq!(input.mouse_motion, Vec2::ZERO);
        assert_eq!(input.cursor, Some(Vec2::new(10.0, 20.0)), "the cursor is not per-frame");
        input.set_cursor(Some(Vec2::new(f32::INFINITY, 0.0)));
        assert_eq!(input.cursor, None);
    }

    #[test]
    fn key_names_round_trip() {
        for key in Key::ALL {
            assert_eq!(Key::from_name(key.name()), Some(key));
            assert_eq!(Key::from_name(&key.name().to_lowercase()), Some(key));
        }
        assert_eq!(Key::from_name("esc"), Some(Key::Escape));
        assert_eq!(Key::from_name("Q"), None);
        assert_eq!(Key::digit(7), Some(Key::Digit7));
        assert_eq!(Key::digit(10), None);
    }

    #[test]
    fn release_all_unsticks_everything() {
        let mut input = Input::default();
        input.press(Key::W);
        input.press_button(MouseButton::Right);
        input.begin_frame();
        input.release_all();
        assert!(!input.pressed(Key::W) && input.just_released(Key::W));
        assert!(!input.button_pressed(MouseButton::Right));
        assert!(input.button_just_released(MouseButton::Right));
    }
}
