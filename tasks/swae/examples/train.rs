//! The same training as `vb terrain train`, without building the whole `vb` binary:
//! `cargo run --release -p swae --example train -- DATA_DIR OUT_FILE EPOCHS MAX_MINUTES [MAX_BATCHES]`.

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 5 {
        anyhow::bail!("usage: train DATA_DIR OUT_FILE EPOCHS MAX_MINUTES [MAX_BATCHES]");
    }
    let (train, val) = swae::train::load_split(std::path::Path::new(&a[1]))?;
    println!("{} training crops, {} held out", train.len(), val.len());
    let opts = swae::train::TrainOptions {
        epochs: a[3].parse()?,
        max_seconds: a[4].parse::<f64>()? * 60.0,
        max_batches: a.get(5).map(|s| s.parse()).transpose()?.unwrap_or(0),
        config: swae::model::Config {
            channels: std::env::var("CH")
                .unwrap_or_else(|_| "8,16,32,64,64".into())
                .split(',')
                .map(|c| c.parse())
                .collect::<Result<_, _>>()?,
            latent: 64,
        },
        loss: swae::model::LossWeights {
            sw: std::env::var("SW").map(|b| b.parse()).unwrap_or(Ok(1.0))?,
            ..Default::default()
        },
        batch: std::env::var("BATCH").map(|b| b.parse()).unwrap_or(Ok(8))?,
        ..Default::default()
    };
    println!("{opts:?}");
    swae::train::train(
        &train,
        &val,
        &opts,
        Some(std::path::Path::new(&a[2])),
        |l| println!("{l}"),
    )?;
    Ok(())
}
