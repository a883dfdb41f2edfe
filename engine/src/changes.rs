//! Change lists for components that are only ever inserted, never written in place.
//!
//! Finding what changed with `Changed<T>` filters is a scan of every matching entity's change
//! ticks: about a millisecond per million entities and filter, every frame, even when nothing
//! changed. The components that the render extraction mirrors ([`crate::scene::MeshInstance`],
//! the lights, decals) are immutable instead (`#[component(immutable)]`: the compiler refuses
//! `&mut`, an edit is an insert), and an `on_insert` hook writes an [`Inserted`] message for
//! each insert. Each consumer reads the messages with its own `MessageReader`, so the work of
//! finding what changed is proportional to what changed. Messages live for two updates
//! ([`App::add_message`] swaps their buffers once per update), so a reader that runs every
//! update sees each one once, wherever in the update the insert happened.

use std::marker::PhantomData;

use bevy_ecs::component::Component;
use bevy_ecs::entity::Entity;
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::message::{Message, Messages};
use bevy_ecs::prelude::ResMut;
use bevy_ecs::world::DeferredWorld;

use crate::app::{App, PreUpdate};

/// A `C` was inserted on `entity` (spawned with it, or replaced by a new value).
#[derive(Message, Debug)]
pub struct Inserted<C: Component> {
    /// The entity that got the component.
    pub entity: Entity,
    marker: PhantomData<fn() -> C>,
}

impl<C: Component> Clone for Inserted<C> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<C: Component> Copy for Inserted<C> {}

impl<C: Component> Inserted<C> {
    /// The message for `entity`.
    pub fn new(entity: Entity) -> Self {
        Self { entity, marker: PhantomData }
    }
}

/// An `on_insert` hook that writes [`Inserted<C>`] (when the app registered it with
/// [`App::add_message`]).
pub fn note_inserted<C: Component>(mut world: DeferredWorld, ctx: HookContext) {
    if world.get_resource::<Messages<Inserted<C>>>().is_some() {
        world.write_message(Inserted::<C>::new(ctx.entity));
    }
}

impl App {
    /// Registers the message `M`: its store, and the swap of its buffers at the start of every
    /// update (in [`PreUpdate`]).
    pub fn add_message<M: Message>(&mut self) -> &mut Self {
        if self.world.get_resource::<Messages<M>>().is_none() {
            self.world.init_resource::<Messages<M>>();
            self.add_systems(PreUpdate, |mut messages: ResMut<Messages<M>>| messages.update());
        }
        self
    }
}
