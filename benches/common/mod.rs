//! Command-line arguments and the timing renderer the benchmarks share.

/// `--frames N` (or `default`), `--quick` and `--only NAME` from the
/// command line.
pub struct BenchArgs {
    /// Frames to measure per configuration.
    pub frames: u32,
    /// Measure 320x240 only.
    pub quick: bool,
    /// Run only the table of this name (the benchmark says which exist).
    #[allow(dead_code)] // not every benchmark has several tables
    pub only: Option<String>,
}

impl BenchArgs {
    /// Reads the process's arguments.
    pub fn parse(default_frames: u32) -> Self {
        let args: Vec<String> = std::env::args().collect();
        let frames = args
            .iter()
            .position(|a| a == "--frames")
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(default_frames);
        let quick = args.iter().any(|a| a == "--quick");
        let only = args
            .iter()
            .position(|a| a == "--only")
            .and_then(|i| args.get(i + 1))
            .cloned();
        Self {
            frames,
            quick,
            only,
        }
    }

    /// The image sizes to measure: 320x240, and 1024x768 unless quick.
    #[allow(dead_code)] // not every benchmark measures several sizes
    pub fn sizes(&self) -> &'static [(u32, u32)] {
        if self.quick {
            &[(320, 240)]
        } else {
            &[(320, 240), (1024, 768)]
        }
    }
}

/// A renderer for timing: GPU timestamps without pipeline-statistics
/// queries, which a driver may pay for (on an H100 they cost nothing
/// measurable: cornell's 1024x768 G-buffer 1.77 ms either way). The
/// benchmarks report time, not invocation counts.
pub fn timing_renderer() -> ssbc::Renderer {
    ssbc::Renderer::new(&ssbc::RendererConfig {
        no_pipeline_statistics: true,
        ..Default::default()
    })
    .expect("renderer")
}
