//! The sandbox game: the reference example of the public API.
