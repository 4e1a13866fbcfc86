//! The window's input as the viewer's actions. The window reports every key
//! and mouse button edge through minifb's `InputCallback` (mouse buttons
//! through the patched minifb in `vendor/minifb`), in the order they came,
//! however long the loop took between two looks; [`Gestures`] turns them
//! into events: a tap of any length is one action, a held key repeats at a
//! stated rate, a press and release that does not move is a click, a drag
//! orbits or pans by the distance it went, the wheel zooms by every notch.

use std::cell::RefCell;
use std::rc::Rc;
use std::time::{Duration, Instant};

use minifb::{Key, MouseButton};

use super::Action;
use super::keys::KEYS;

/// A held key waits this long before it repeats ...
pub const REPEAT_DELAY: Duration = Duration::from_millis(300);
/// ... then repeats this often, while the viewer keeps up.
pub const REPEAT_EVERY: Duration = Duration::from_millis(50);

/// Pixels a press may move and still count as a click.
const CLICK_SLACK: f32 = 3.0;

/// One edge the window reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// A key went down (`true`) or up.
    Key(Key, bool),
    /// A mouse button went down (`true`) or up, with the pointer there.
    Button(MouseButton, bool, (f32, f32)),
}

/// Where the window's callback leaves its inputs until the loop takes them.
#[derive(Clone, Default)]
pub struct Inbox(Rc<RefCell<Vec<Input>>>);

impl Inbox {
    /// The inputs since the last call, oldest first.
    pub fn take(&self) -> Vec<Input> {
        std::mem::take(&mut self.0.borrow_mut())
    }
}

impl minifb::InputCallback for Inbox {
    fn add_char(&mut self, _uni_char: u32) {}

    fn set_key_state(&mut self, key: Key, state: bool) {
        self.0.borrow_mut().push(Input::Key(key, state));
    }

    fn set_mouse_button_state(&mut self, button: MouseButton, state: bool, x: f32, y: f32) {
        self.0.borrow_mut().push(Input::Button(button, state, (x, y)));
    }
}

/// An action, and what the user did to ask for it (for the events log).
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    pub action: Action,
    pub source: String,
    /// Whether it may be merged with the camera moves next to it: the
    /// steps of one drag or of the wheel, never a key's own action.
    pub mergeable: bool,
}

impl Event {
    fn new(action: Action, source: String, mergeable: bool) -> Self {
        Self { action, source, mergeable }
    }
}

/// A key held down: its action repeats from `next`.
struct Held {
    key: Key,
    action: Action,
    next: Instant,
}

/// A mouse button held down.
struct Press {
    button: MouseButton,
    /// Where it went down, and where the last drag step ended.
    at: (f32, f32),
    last: (f32, f32),
    /// Whether it has gone further than a click may.
    dragged: bool,
}

/// The state the inputs build up between the loop's turns.
#[derive(Default)]
pub struct Gestures {
    held: Option<Held>,
    shift: bool,
    press: Option<Press>,
    /// Escape was pressed.
    pub quit: bool,
}

impl Gestures {
    /// The events of `inputs` (oldest first), of the pointer now at
    /// `pointer` and the wheel turned by `wheel` notches since the last
    /// turn, and the held key's repeats that are due at `now` (only while
    /// the viewer has `caught_up`, so that a held key never builds a backlog).
    pub fn events(
        &mut self,
        inputs: &[Input],
        pointer: Option<(f32, f32)>,
        wheel: f32,
        now: Instant,
        caught_up: bool,
    ) -> Vec<Event> {
        let mut events = vec![];
        for &input in inputs {
            match input {
                Input::Key(key, down) => events.extend(self.key(key, down, now)),
                Input::Button(button, down, at) => events.extend(self.button(button, down, at)),
            }
        }
        // The pointer is polled once a turn, and may not yet have seen the
        // motion that came before a press this turn: the press's own place
        // stands for it until the next look (else a quick click after a
        // move could start as a drag from the old place).
        let pressed_now = inputs.iter().any(|i| matches!(i, Input::Button(_, true, _)));
        if let Some(at) = pointer.filter(|_| !pressed_now) {
            events.extend(self.pointer_at(at));
        }
        let notches = wheel.round();
        if notches != 0.0 {
            events.push(Event::new(Action::wheel(notches), format!("wheel {notches}"), true));
        }
        events.extend(self.repeat(now, caught_up));
        events
    }

    /// A key's edge: a press (not the window system's own repeat of a key
    /// already down) is its action at once.
    fn key(&mut self, key: Key, down: bool, now: Instant) -> Option<Event> {
        match key {
            Key::Escape if down => self.quit = true,
            Key::LeftShift | Key::RightShift => self.shift = down,
            _ => {}
        }
        if !down {
            self.held.take_if(|held| held.key == key);
            return None;
        }
        if self.held.as_ref().is_some_and(|held| held.key == key) {
            return None;
        }
        let (name, action) = KEYS.iter().find(|(_, k, _)| *k == key).map(|&(name, _, action)| (name, action))?;
        self.held = action.repeats().then(|| Held { key, action, next: now + REPEAT_DELAY });
        Some(Event::new(action, format!("key {name}"), false))
    }

    /// The held key's repeat, when one is due and the viewer has caught up.
    fn repeat(&mut self, now: Instant, caught_up: bool) -> Option<Event> {
        let held = self.held.as_mut().filter(|held| caught_up && now >= held.next)?;
        // Counted from now, not from when it was due: a slow viewer gets fewer repeats, not a burst.
        held.next = now + REPEAT_EVERY;
        let name = KEYS.iter().find(|(_, k, _)| *k == held.key).map_or("?", |(name, ..)| name);
        Some(Event::new(held.action, format!("repeat {name}"), false))
    }

    /// A mouse button's edge: the left or right button starts a press; its
    /// release ends a drag, or makes a click where it went down.
    fn button(&mut self, button: MouseButton, down: bool, at: (f32, f32)) -> Vec<Event> {
        if !matches!(button, MouseButton::Left | MouseButton::Right) {
            return vec![];
        }
        if down {
            if self.press.is_none() {
                self.press = Some(Press { button, at, last: at, dragged: false });
            }
            return vec![];
        }
        if self.press.as_ref().is_none_or(|press| press.button != button) {
            return vec![];
        }
        let mut events: Vec<Event> = self.pointer_at(at).into_iter().collect();
        let press = self.press.take().expect("a press");
        if !press.dragged {
            let (x, y) = (press.at.0.max(0.0) as u32, press.at.1.max(0.0) as u32);
            events.push(Event::new(Action::SelectAt(x, y), format!("click {x},{y}"), false));
        }
        events
    }

    /// The drag step to the pointer at `at`, while a button is down.
    fn pointer_at(&mut self, at: (f32, f32)) -> Option<Event> {
        let shift = self.shift;
        let press = self.press.as_mut()?;
        press.dragged |= (at.0 - press.at.0).abs() > CLICK_SLACK || (at.1 - press.at.1).abs() > CLICK_SLACK;
        if !press.dragged || press.last == at {
            return None;
        }
        let (dx, dy) = (at.0 - press.last.0, at.1 - press.last.1);
        press.last = at;
        Some(match press.button == MouseButton::Right || shift {
            true => Event::new(Action::Pan(dx, dy), format!("pan {dx},{dy}"), true),
            false => Event::new(Action::drag(dx, dy), format!("drag {dx},{dy}"), true),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn actions(events: &[Event]) -> Vec<Action> {
        events.iter().map(|e| e.action).collect()
    }

    #[test]
    fn a_tap_within_one_turn_is_one_action_and_a_held_key_repeats_at_the_stated_rate() {
        let mut g = Gestures::default();
        let t0 = Instant::now();
        let tap = [Input::Key(Key::Right, true), Input::Key(Key::Right, false)];
        assert_eq!(actions(&g.events(&tap, None, 0.0, t0, true)), [Action::Move(0, 1.0)]);
        assert!(g.events(&[], None, 0.0, t0 + 2 * REPEAT_DELAY, true).is_empty(), "released: no repeat");
        // Held: the press, nothing before the delay, then one repeat each period.
        let press = [Input::Key(Key::Right, true)];
        assert_eq!(g.events(&press, None, 0.0, t0, true).len(), 1);
        let before = t0 + REPEAT_DELAY - Duration::from_millis(1);
        assert!(g.events(&[], None, 0.0, before, true).is_empty());
        let mut repeats = 0;
        for ms in (300..1300).step_by(5) {
            repeats += g.events(&[], None, 0.0, t0 + Duration::from_millis(ms), true).len();
        }
        assert_eq!(repeats, 20, "a second of repeats at one per {REPEAT_EVERY:?}");
        // The window system's own repeats of a key already down add nothing.
        assert!(g.events(&press, None, 0.0, t0 + Duration::from_millis(1301), false).is_empty());
        // While the viewer is behind, no repeats pile up.
        assert!(g.events(&[], None, 0.0, t0 + Duration::from_secs(5), false).is_empty());
        // Toggles do not repeat.
        let mut g = Gestures::default();
        g.events(&[Input::Key(Key::V, true)], None, 0.0, t0, true);
        assert!(g.events(&[], None, 0.0, t0 + Duration::from_secs(2), true).is_empty());
    }

    #[test]
    fn the_help_card_states_the_repeat_rate() {
        let delay = format!("after {} s", REPEAT_DELAY.as_secs_f32());
        let rate = format!("{} a second", 1000 / REPEAT_EVERY.as_millis());
        assert!(super::super::keys::REPEAT_HELP.contains(&delay) && super::super::keys::REPEAT_HELP.contains(&rate));
    }

    #[test]
    fn taps_between_two_turns_all_count() {
        let mut g = Gestures::default();
        let taps: Vec<Input> =
            (0..5).flat_map(|_| [Input::Key(Key::Left, true), Input::Key(Key::Left, false)]).collect();
        assert_eq!(g.events(&taps, None, 0.0, Instant::now(), false).len(), 5);
    }

    #[test]
    fn a_click_within_one_turn_selects_and_a_drag_does_not() {
        let mut g = Gestures::default();
        let now = Instant::now();
        let click =
            [Input::Button(MouseButton::Left, true, (17.0, 9.0)), Input::Button(MouseButton::Left, false, (18.0, 9.0))];
        assert_eq!(actions(&g.events(&click, Some((40.0, 40.0)), 0.0, now, true)), [Action::SelectAt(17, 9)]);
        // Down, moved, up within one turn: the drag goes the whole way, and selects nothing.
        let drag = [
            Input::Button(MouseButton::Left, true, (10.0, 10.0)),
            Input::Button(MouseButton::Left, false, (30.0, 15.0)),
        ];
        assert_eq!(actions(&g.events(&drag, None, 0.0, now, true)), [Action::drag(20.0, 5.0)]);
        // Over several turns, the steps add up to the distance gone.
        let down = [Input::Button(MouseButton::Right, true, (10.0, 10.0))];
        let mut steps = actions(&g.events(&down, Some((10.0, 10.0)), 0.0, now, true));
        steps.extend(actions(&g.events(&[], Some((12.0, 10.0)), 0.0, now, true)));
        steps.extend(actions(&g.events(&[], Some((20.0, 14.0)), 0.0, now, true)));
        let up = [Input::Button(MouseButton::Right, false, (25.0, 14.0))];
        steps.extend(actions(&g.events(&up, Some((25.0, 14.0)), 0.0, now, true)));
        assert_eq!(steps, [Action::Pan(10.0, 4.0), Action::Pan(5.0, 0.0)], "within the slack, then the rest");
    }

    #[test]
    fn a_press_with_a_pointer_polled_before_the_move_to_it_is_still_a_click() {
        let mut g = Gestures::default();
        let now = Instant::now();
        // The press came at (170, 150); the pointer, polled this turn, still says (160, 60).
        let down = [Input::Button(MouseButton::Left, true, (170.0, 150.0))];
        let mut seen = actions(&g.events(&down, Some((160.0, 60.0)), 0.0, now, true));
        seen.extend(actions(&g.events(&[], Some((170.0, 150.0)), 0.0, now, true)));
        let up = [Input::Button(MouseButton::Left, false, (170.0, 150.0))];
        seen.extend(actions(&g.events(&up, Some((170.0, 150.0)), 0.0, now, true)));
        assert_eq!(seen, [Action::SelectAt(170, 150)]);
    }

    #[test]
    fn every_wheel_notch_zooms_and_escape_quits() {
        let mut g = Gestures::default();
        let events = g.events(&[Input::Key(Key::Escape, true)], None, 3.0, Instant::now(), true);
        assert_eq!(actions(&events), [Action::wheel(3.0)]);
        assert!(g.quit);
    }
}
