//! Without a usable Vulkan device the render plugin says so and the app ends with that error; it
//! does not panic. (Its own test binary: it points the Vulkan loader at a driver list that does
//! not exist, which must not reach the other tests' processes.)

use engine::app::AppExit;
use engine::prelude::*;
use plugins::{GpuPlugin, GpuRenderer, RenderPlugin, RenderSettings, RenderStats};

#[test]
fn without_a_vulkan_device_the_app_exits_with_an_error_naming_the_problem() {
    unsafe_env::set("VK_DRIVER_FILES", "/nonexistent/no_driver.json");
    unsafe_env::set("VK_ICD_FILENAMES", "/nonexistent/no_driver.json");
    let mut app = App::new();
    app.add_plugins(RenderPlugin::new(RenderSettings { size: (64, 48), ..Default::default() }));
    app.add_plugins(GpuPlugin::default());
    app.world.spawn((Camera::default(), Transform::default()));
    app.update();
    assert!(!app.world.contains_resource::<GpuRenderer>(), "no renderer without a device");
    let error = app.world.resource::<RenderStats>().last_error.clone().expect("the error is kept");
    eprintln!("{error}");
    assert!(error.starts_with("could not start the renderer"), "{error}");
    assert!(matches!(app.world.get_resource::<AppExit>(), Some(AppExit::Error(e)) if *e == error));
    let ran = app.run();
    assert_eq!(ran.expect_err("run reports the error").to_string(), error);
}

mod unsafe_env {
    /// Sets an environment variable for this process.
    pub fn set(key: &str, value: &str) {
        // SAFETY: called from this binary's single test before any other thread could read the
        // environment (the test harness's threads do not).
        unsafe { std::env::set_var(key, value) };
    }
}
