//! Without a usable Vulkan device the render plugin says so and the app ends with that error; it
//! does not panic. It runs in a process of its own whose Vulkan loader is pointed at a driver
//! list that does not exist, which must not reach the other tests.

use engine::app::AppExit;
use engine::prelude::*;
use plugins::{GpuPlugin, GpuRenderer, RenderPlugin, RenderSettings, RenderStats};

const NO_DRIVER: &str = "/nonexistent/no_driver.json";

#[test]
fn without_a_vulkan_device_the_app_exits_with_an_error_naming_the_problem() {
    let env = [("VK_DRIVER_FILES", NO_DRIVER), ("VK_ICD_FILENAMES", NO_DRIVER)];
    if !tests::in_own_process(module_path!(), "without_a_vulkan_device_the_app_exits_with_an_error_naming_the_problem", &env) {
        return;
    }
    assert_eq!(std::env::var("VK_DRIVER_FILES").as_deref(), Ok(NO_DRIVER), "the child sees no driver");
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
