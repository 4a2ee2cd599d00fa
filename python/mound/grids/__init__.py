"""The verdict's grids of simulated sites, each flown (mound.sim), reconstructed and judged
(mound_recon): what the learned verdict is trained and judged on (`mound sim grid`)."""
