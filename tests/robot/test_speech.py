"""Speech: audio in the recogniser's format, the command grammar from the world, recognition of spoken commands
(espeak-ng voices and speeds, clean and in noise) and the plans they lead to, and synthesis."""

from __future__ import annotations

import io
import re
import wave

import numpy as np
import pytest

from harness.speech_trials import run_trials, spoken_cases, summarise, word_errors
from robot.planning.world_context import WorldContext
from robot.speech.asr import ALTERNATIVES_KEPT, AUTO_RUN_CONFIDENCE
from robot.speech.audio import RATE, Audio, AudioError, add_noise, from_samples, read_wav_bytes
from robot.speech.denoise import denoise
from robot.speech.grammar import build_grammar
from robot.speech.sphinx import PocketSphinxASR
from robot.speech.tts import TTSError, synthesize, synthesize_audio


@pytest.fixture(scope="module")
def world() -> WorldContext:
    from robot.model.world import generate_world

    return WorldContext.from_layout(generate_world(0))


@pytest.fixture(scope="module")
def asr(world) -> PocketSphinxASR:
    return PocketSphinxASR(world.objects, world.places)


def _wav(samples: np.ndarray, rate: int, width: int, channels: int) -> bytes:
    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as out:
        out.setnchannels(channels)
        out.setsampwidth(width)
        out.setframerate(rate)
        out.writeframes(samples.tobytes())
    return buffer.getvalue()


def test_any_pcm_wav_becomes_16khz_mono() -> None:
    t = np.arange(44100) / 44100
    tone = (np.sin(2 * np.pi * 440 * t) * 20000).astype("<i2")
    stereo = np.stack([tone, tone], axis=1)
    audio = read_wav_bytes(_wav(stereo, 44100, 2, 2))
    assert audio.samples.dtype == np.int16 and abs(audio.duration_s - 1.0) < 0.001
    spectrum = np.abs(np.fft.rfft(audio.samples))
    assert abs(np.argmax(spectrum) * RATE / len(audio.samples) - 440) < 2  # still a 440 Hz tone
    eight_bit = read_wav_bytes(_wav((tone // 256 + 128).astype(np.uint8), 44100, 1, 1))
    assert np.corrcoef(eight_bit.samples, audio.samples)[0, 1] > 0.99
    with pytest.raises(AudioError, match="not a PCM WAV"):
        read_wav_bytes(b"ID3 this is an mp3")


def test_noise_is_added_at_the_asked_signal_to_noise_ratio() -> None:
    t = np.arange(RATE) / RATE
    clean = from_samples(np.sin(2 * np.pi * 300 * t) * 0.5, RATE)
    noisy = add_noise(clean, 10.0, seed=1)
    noise = noisy.samples.astype(float) - clean.samples
    snr = 10 * np.log10(np.mean(clean.samples.astype(float) ** 2) / np.mean(noise**2))
    assert 9.5 < snr < 10.5


def test_steady_noise_is_taken_out_and_clean_speech_left_alone() -> None:
    clean = synthesize_audio("pick up the red mug from the kitchen counter", "en-us", 160)
    noisy = add_noise(clean, 10.0, seed=2)

    def snr_db(samples: np.ndarray) -> float:
        residue = samples.astype(float) - clean.samples
        return 10 * np.log10(np.mean(clean.samples.astype(float) ** 2) / np.mean(residue**2))

    assert snr_db(denoise(noisy.samples)) > snr_db(noisy.samples) + 3.0
    assert np.array_equal(denoise(clean.samples), clean.samples)  # espeak's digital silence: no noise to remove


def test_the_grammar_names_the_worlds_things_and_accepts_only_whole_commands(world) -> None:
    grammar = build_grammar(world.objects, world.places, vocabulary=None)
    assert "red mug" in grammar.text and "living room table" in grammar.text and "charging dock" in grammar.text
    assert grammar.accepts("pick up the red mug from the kitchen counter")
    assert grammar.accepts("please bring the apple to the living room table")
    assert grammar.accepts("wait for five seconds")
    assert grammar.accepts("stop right now") and grammar.accepts("emergency stop")
    assert not grammar.accepts("go to the charging")  # the partial path a lost decoder returns
    assert not grammar.accepts("what is the weather like today")


def test_phrases_with_words_the_dictionary_lacks_are_left_out(world, asr) -> None:
    objects = {**world.objects, "zorblax gizmo": ("zorblax",)}
    vocabulary = set(re.findall(r"[a-z']+", asr.grammar.text)) | {"gizmo"}
    grammar = build_grammar(objects, world.places, vocabulary=vocabulary)
    assert grammar.left_out == ("zorblax gizmo", "zorblax")
    assert "zorblax" not in grammar.text


def test_a_spoken_command_is_heard_whole(asr) -> None:
    transcript = asr.transcribe(synthesize_audio("bring the red mug to the living room table", "en-us", 160))
    assert transcript.text == "bring the red mug to the living room table"
    assert transcript.in_grammar and transcript.confidence > 0.5  # other speech: median 0.06 (README)
    # how fast it decodes is `humanoid bench voice`'s to measure (a full run on a loaded machine took 0.56 x real time)
    assert transcript.audio_s > 0 and transcript.decode_s > 0


NOT_COMMANDS = (
    "what is the weather like today",
    "turn on the television please",
    "the quick brown fox jumps over the lazy dog",
    "call my mother on the phone",
)


@pytest.mark.parametrize("text", NOT_COMMANDS)
def test_speech_that_is_no_command_gets_a_confidence_that_asks_the_operator(asr, text: str) -> None:
    # a grammar maps any speech onto some sentence of its own: the likelihood ratio must give it away
    transcript = asr.transcribe(synthesize_audio(text, "en-us", 160))
    assert transcript.confidence < AUTO_RUN_CONFIDENCE, transcript


def test_silence_is_nothing(asr) -> None:
    silence = asr.transcribe(Audio(np.zeros(RATE, np.int16)))
    assert silence.text == "" and silence.confidence == 0.0


def test_word_errors_count_substitutions_insertions_and_deletions() -> None:
    assert word_errors("pick up the red mug", "pick up the red mug") == (0, 5)
    assert word_errors("pick up the red mug", "pick the rod mug now") == (3, 5)
    assert word_errors("Living-room table!", "living room table") == (0, 3)


def test_spoken_commands_in_three_voices_clean_and_in_noise_give_the_right_plans() -> None:
    cases = spoken_cases()
    assert len(cases) >= 40
    # each command in one of the three voices, in turn (every voice in every pair is `humanoid bench voice`'s)
    voices = (("en-us", 160), ("en-gb", 175), ("en-us", 140))
    trials = [t for i, voice in enumerate(voices) for t in run_trials(voices=(voice,), cases=cases[i :: len(voices)])]
    summary = summarise(trials)
    clean, noisy = summary["clean"], summary["noisy_10db"]
    assert clean["wer"] <= 0.10, clean
    assert noisy["wer"] <= 0.20, noisy
    assert clean["plan_right"] >= 0.90, clean
    assert noisy["plan_right"] >= 0.90, noisy  # decoding is deterministic: 0.914 here (clean 0.929)
    # latency is a benchmark's business (`humanoid bench voice`), not a unit test's: it is only reported here
    assert clean["end_of_speech_to_plan_ms"]["p50"] > 0
    confidence = summary["confidence"]
    assert confidence["right_plans_mean"] > confidence["wrong_plans_mean"] + 0.15


def test_synthesis_makes_a_wav_and_refuses_what_it_cannot_say() -> None:
    wav = synthesize("I have picked up the red mug.")
    audio = read_wav_bytes(wav)
    assert 1.0 < audio.duration_s < 4.0
    with pytest.raises(TTSError, match="nothing to say"):
        synthesize("   ")
    with pytest.raises(TTSError, match="at most 500 characters"):
        synthesize("word " * 200)
    # a variant espeak-ng does not have would be spoken as the plain accent, without a word: refused, naming the one
    with pytest.raises(TTSError, match=r"no voice variant 'annie'.*Annie"):
        synthesize("hello", "en-us+annie")
    assert read_wav_bytes(synthesize("hello", "en-us+Annie")).duration_s > 0.3


def test_whisper_without_a_model_says_what_to_set(tmp_path, world) -> None:
    from robot.speech.asr import ASRError
    from robot.speech.engines import build_recognizer

    with pytest.raises(ASRError, match=r"model\.bin"):
        build_recognizer("whisper", world.objects, world.places, str(tmp_path))  # a directory without a model
    with pytest.raises(ASRError, match="unknown speech engine 'vosk'"):
        build_recognizer("vosk", world.objects, world.places)


@pytest.fixture(scope="module")
def whisper(world):
    """tiny.en alone, as the first model hears."""
    from robot.speech.whisper import WhisperASR, packaged_model_dir

    assert packaged_model_dir() is not None, "the test set-up installs the whisper extra with its packaged model"
    return WhisperASR("", world.objects, world.places, second_model="off")


@pytest.fixture(scope="module")
def whisper_twice(world):
    """As the app hears by default: tiny.en, and the base model for what tiny.en is not sure of."""
    from robot.speech.whisper import WhisperASR
    from robot.speech.whisper_models import packaged_second_model_dir

    assert packaged_second_model_dir() is not None, "the test set-up installs the whisper extra with the base model"
    return WhisperASR("", world.objects, world.places)


def test_what_the_first_model_is_not_sure_of_is_heard_again_by_the_second(whisper, whisper_twice) -> None:
    from harness.spoken_cases import Voice, utterance

    # a development-set recording of the speech bench's (noisy, seed 14): tiny.en hears "Hey, robot, ramp the apple
    # for me." and is not sure of it
    audio = utterance("hey robot, grab the apple for me", Voice("en-us+f2", 140, 60), 10.0, 14)
    first = whisper.transcribe(audio)
    assert "grab the apple" not in first.text.lower() and not first.sure and not first.heard_again, first
    twice = whisper_twice.transcribe(audio)
    assert twice.heard_again and "grab the apple for me" in twice.text.lower(), twice
    assert first.text in twice.alternatives  # the first model's wording stays among the others
    assert not twice.sure and twice.confidence == first.confidence  # two hearings never make it run unasked
    # what the first model is sure of is not heard again
    sure = whisper_twice.transcribe(synthesize_audio("go to the charging dock", "en-us", 160))
    assert sure.sure and not sure.heard_again and sure.text.lower().rstrip(".") == "go to the charging dock", sure


def test_a_second_hearing_puts_the_second_models_wordings_first_then_the_firsts_each_once() -> None:
    from robot.speech.whisper import Hypothesis, heard_twice

    first = [
        Hypothesis("Head robot, ramped the apple.", -0.5, -0.5),
        Hypothesis("Hey robot, grab the apple.", -0.7, -0.7),
    ]
    second = [
        Hypothesis("Hey robot, grab the apple.", -0.2, -0.2),
        Hypothesis("Hey robot grab the apple!", -0.3, -0.3),  # the same words
        Hypothesis("Hey robot, grab the apples.", -0.4, -0.4),
    ]
    assert heard_twice(first, second) == (
        "Hey robot, grab the apple.",
        ("Hey robot, grab the apples.", "Head robot, ramped the apple."),
    )
    assert heard_twice([Hypothesis("", -1.0, -1.0)], second[:1]) == ("Hey robot, grab the apple.", ())
    # the multilingual model's likeliest with a word in another script: no transcript, still an alternative
    drifted = [Hypothesis("都 hey robot, grab the apples.", -0.1, -0.1), *second]
    assert heard_twice(first, drifted) == (
        "Hey robot, grab the apple.",
        ("都 hey robot, grab the apples.", "Head robot, ramped the apple."),
    )
    drifted_again = [Hypothesis("都 hey robot, grab the apple.", -0.1, -0.1), *second]  # the same words, drifted
    assert heard_twice(first, drifted_again) == (
        "Hey robot, grab the apple.",
        ("Hey robot, grab the apples.", "Head robot, ramped the apple."),
    )


def test_the_second_model_is_joined_from_its_two_packages_once_and_can_be_turned_off(tmp_path, monkeypatch) -> None:
    from robot.speech import whisper_models
    from robot.speech.asr import ASRError
    from robot.speech.whisper import _second_model_path

    one, two = tmp_path / "part1", tmp_path / "part2"
    one.mkdir(), two.mkdir()
    (one / "model.bin.part1").write_bytes(b"first half ")
    (two / "model.bin.part2").write_bytes(b"second half")
    for name in whisper_models.BASE_FILES:
        (two / name).write_text(f"{name} of the model")
    monkeypatch.setattr(whisper_models, "_part_dirs", lambda: [one, two])
    cache = tmp_path / "cache"
    joined = whisper_models.packaged_second_model_dir(cache)
    assert joined is not None and (joined / "model.bin").read_bytes() == b"first half second half"
    assert (joined / "tokenizer.json").read_text() == "tokenizer.json of the model"
    made = (joined / "model.bin").stat().st_mtime_ns
    assert whisper_models.packaged_second_model_dir(cache) == joined  # once: the next process reads it
    assert (joined / "model.bin").stat().st_mtime_ns == made
    assert [p.name for p in cache.iterdir() if not p.name.startswith(".joining.lock")] == [joined.name]
    monkeypatch.setattr(whisper_models, "_part_dirs", lambda: None)  # the packages not installed
    assert whisper_models.packaged_second_model_dir(cache) is None and whisper_models.second_model_dir("auto") is None
    assert whisper_models.second_model_dir("off") is None
    with pytest.raises(ASRError, match="no second whisper model"):
        _second_model_path(str(tmp_path / "nowhere"), tmp_path)


def test_whisper_is_the_default_and_hears_everyday_wording_the_same_way_every_time(whisper) -> None:
    from robot.speech.engines import resolve_engine

    assert resolve_engine("auto") == "whisper" and resolve_engine("pocketsphinx") == "pocketsphinx"
    said = synthesize_audio("um, could you please bring me the water bottle", "en-gb", 170)
    audio = add_noise(said, 10.0, seed=4, colour="brown")
    first, second = whisper.transcribe(audio), whisper.transcribe(audio)
    assert first.text == second.text and first.confidence == second.confidence  # temperature 0: no sampling
    assert "bring me the water bottle" in first.text.lower(), first  # the world's names as hints
    assert first.engine == "whisper" and 0.0 < first.confidence <= 1.0


def test_whisper_is_surer_of_what_it_heard_right_than_of_what_it_did_not(whisper) -> None:
    clean = whisper.transcribe(synthesize_audio("go to the charging dock", "en-us", 160))
    assert clean.text.lower().rstrip(".") == "go to the charging dock" and clean.sure, clean
    mumble = whisper.transcribe(add_noise(synthesize_audio("grab the apple", "en-us+f2", 230), 0.0, 2, "brown"))
    assert mumble.confidence < clean.confidence, (mumble, clean)
    assert whisper.transcribe(Audio(np.zeros(RATE, np.int16))).sure is False  # silence runs nothing


def test_a_name_whispers_hints_put_in_place_of_what_was_said_is_not_sure_enough_to_run(whisper) -> None:
    """ "pick up the book" (the book is not in the world) heard as "Pick up the mug.": whisper's prompt lists the mug.
    Heard right, a command with the world's names stays sure."""
    from harness.spoken_cases import Voice, utterance
    from robot.speech.whisper import UNSURE_NAME_CONFIDENCE

    # recordings of the speech bench's, clean (the development set's seed 363, the first held-out set's 377)
    book = whisper.transcribe(utterance("pick up the book", Voice("en-gb", 175), None, 363))
    assert "mug" in book.text.lower() and book.unsure_names == ("mug",), book
    assert not book.sure and book.confidence <= UNSURE_NAME_CONFIDENCE, book
    garage = whisper.transcribe(
        utterance("take the apple to the garage", Voice("en-gb-scotland+m3", 150, 45), None, 377)
    )
    assert "bottle" in garage.text.lower() and garage.unsure_names == ("bottle",) and not garage.sure, garage
    # (in Voice("en-gb", 175) the mug's evidence sits at the threshold: sure on one machine, not on another)
    right = whisper.transcribe(utterance("bring the red mug to the table", Voice("en-us", 160), None, 363))
    assert right.text.lower().rstrip(".") == "bring the red mug to the table", right
    assert right.sure and right.unsure_names == (), right


def test_a_misheard_command_is_read_from_the_next_wording_whisper_heard(whisper) -> None:
    from harness.spoken_cases import Voice, utterance
    from robot.model.world import generate_world
    from robot.planning.context import PlanningContext
    from robot.planning.heard import first_readable
    from robot.planning.pipeline import PlannerConfig, build_pipeline
    from robot.planning.planner import PlanningError
    from robot.planning.world_context import WorldContext

    planner = build_pipeline(PlannerConfig(backend="rules"))
    context = PlanningContext(WorldContext.from_layout(generate_world(0)))
    # a development-set utterance whisper hears as "That's the coffee cup." (a recording of the bench's, seed 67)
    heard = whisper.transcribe(utterance("fetch the coffee cup", Voice("en-gb", 175), None, 67))
    with pytest.raises(PlanningError):
        planner.plan(heard.text, context)
    assert heard.alternatives and all(a.lower() != heard.text.lower() for a in heard.alternatives), heard
    wording, planned = first_readable(planner, heard.alternatives, context)
    assert "fetch the coffee cup" in wording.lower()
    assert ("pick_object", "red mug") in [(s.action, s.args.get("object")) for s in planned.plan.steps]


def test_a_command_is_read_in_a_ten_second_window_and_a_word_or_two_or_a_long_speech_in_the_whole_one() -> None:
    from robot.speech.whisper import window_frames

    full, per_second = 3000, 100  # whisper's 30 s window in feature frames, 100 frames a second
    assert window_frames(250, full, per_second) == 1000  # a 2.5 s command: 10 s
    assert window_frames(120, full, per_second) == full  # "stop!": the window whisper was trained on
    assert window_frames(1200, full, per_second) == full  # longer than the short window
    assert window_frames(250, full, per_second) % 2 == 0  # the encoder's convolution halves it


def test_a_sentence_written_twice_in_a_row_is_kept_once_and_other_sentences_are_left_alone() -> None:
    from robot.speech.whisper import without_repeats

    assert without_repeats("What do you see? What do you see?") == "What do you see?"
    assert without_repeats("Go home. go home!") == "Go home."
    assert without_repeats("Go to the table. Then go home.") == "Go to the table. Then go home."
    assert without_repeats("Stop, stop, stop!") == "Stop, stop, stop!"  # one sentence: words said again stay
    assert without_repeats("") == ""


def test_a_command_read_in_the_short_window_is_heard_word_for_word(whisper) -> None:
    audio = synthesize_audio("take the apple to the table", "en-us", 160)
    assert whisper.transcribe(audio).text.lower().rstrip(".") == "take the apple to the table"


def test_whispers_alternatives_are_the_other_wordings_near_the_best_once_each() -> None:
    from robot.speech.whisper import Hypothesis, alternatives

    beam = [
        Hypothesis("Take the cup and group it on the counter.", -0.10, -0.1),
        Hypothesis("Take the cup and glue it on the counter.", -0.32, -0.3),
        Hypothesis("Take the cup and group it on the counter!", -0.34, -0.3),  # the best again, punctuated
        Hypothesis("Take the cup and put it on the counter.", -0.38, -0.3),
        Hypothesis("Take a cop and put it on the counter.", -0.55, -0.5),  # too far below the best
    ]
    assert alternatives(beam) == ("Take the cup and glue it on the counter.", "Take the cup and put it on the counter.")
    assert alternatives(beam[:1]) == () and alternatives([]) == ()


def test_a_wording_in_another_script_is_kept_to_plan_from_but_cannot_make_a_command_a_stop() -> None:
    from dataclasses import replace

    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop
    from robot.speech.whisper import Hypothesis, alternatives

    beam = [
        Hypothesis("Walk to the counter, the stop.", -0.10, -0.1),
        Hypothesis("Walk to the counter,\u60a8 stop!", -0.20, -0.2),  # the multilingual model's drift
        Hypothesis("Walk to the café, then stop.", -0.25, -0.2),  # a Latin letter stays readable
    ]
    # still a wording to plan from (the planner reads "都 hold on for four seconds."), but not one to stop on
    assert alternatives(beam) == ("Walk to the counter,\u60a8 stop!", "Walk to the café, then stop.")
    heard = Transcript(beam[0].text, 0.9, "whisper", False, 2.0, 0.3, alternatives=alternatives(beam))
    assert not transcript_is_stop(heard)
    short = Transcript("Hard to beat.", 0.3, "whisper", False, 1.0, 0.3, further_wordings=("\u60a8 stop now!",))
    assert not transcript_is_stop(short)
    assert transcript_is_stop(replace(short, further_wordings=("Stop it now!",)))


@pytest.fixture(scope="module")
def spotter(world):
    from robot.speech.stop_word import StopSpotter

    return StopSpotter(world.objects, world.places)


def _padded(text: str, voice: str, wpm: int, snr_db: float | None = None) -> Audio:
    """As a push-to-talk recording: a little quiet before and after the words, a quiet room or brown noise."""
    words = synthesize_audio(text, voice, wpm).samples
    padded = Audio(np.concatenate([np.zeros(6400, np.int16), words, np.zeros(4800, np.int16)]))
    return add_noise(padded, 40.0, seed=7) if snr_db is None else add_noise(padded, snr_db, seed=7, colour="brown")


@pytest.mark.parametrize(
    ("text", "voice", "wpm", "snr_db"),
    [
        ("stop", "en-us", 160, None),
        ("halt", "en-gb", 175, None),
        ("freeze", "en-us", 150, 10.0),
        ("stop right now", "en-gb", 160, None),
        ("emergency stop", "en-us", 150, 10.0),
    ],
)
def test_a_stop_phrase_alone_or_with_a_few_words_is_a_spoken_stop(spotter, text, voice, wpm, snr_db) -> None:
    verdict = spotter.spot(_padded(text, voice, wpm, snr_db))
    assert verdict.stop and verdict.spotted, verdict


@pytest.mark.parametrize(
    "text",
    [
        "go to the dock and stop there",
        "don't stop until you reach the table",
        "please bring me the red mug",
        "head home please",
        "walk over to the kitchen counter",
    ],
)
def test_stop_inside_a_command_and_words_that_sound_like_it_are_no_spoken_stop(spotter, text) -> None:
    for voice, wpm, snr_db in (("en-us", 160, None), ("en-gb", 170, 10.0)):
        assert not spotter.spot(_padded(text, voice, wpm, snr_db)).stop, (text, voice)


@pytest.mark.parametrize(
    ("set_name", "text", "voice", "snr_db", "seed"),
    [
        ("dev", "open the window", "en-us+f2@140", None, 397),  # streamed as "robot ok halt"
        ("heldout6", "go back to the start", "en-us-nyc+john@170", None, 103),  # streamed as "robot stop"
    ],
)
def test_a_command_the_streamed_grammar_fits_poorly_to_a_stop_is_looked_at_again(
    spotter, set_name, text, voice, snr_db, seed
) -> None:
    """The grammar maps any speech onto one of its sentences: these were taken for a stop before its fit against a
    free phone loop was checked."""
    from harness.spoken_cases import SETS, utterance

    spoken = SETS[set_name]
    audio = utterance(text, next(v for v in spoken.voices if v.label() == voice), snr_db, seed)
    verdict = spotter.spot(audio)
    assert verdict.spotted and not verdict.stop, verdict


def test_the_spotter_gives_the_same_verdict_however_the_audio_is_cut_into_blocks(spotter) -> None:
    audio = _padded("stop now", "en-us", 150)
    verdicts = []
    for block in (480, 1600, len(audio.samples)):
        for start in range(0, len(audio.samples), block):
            spotter.feed(audio.samples[start : start + block])
        verdicts.append(spotter.finish())
    assert [(v.stop, v.spotted, v.heard) for v in verdicts[1:]] == [
        (v.stop, v.spotted, v.heard) for v in verdicts[:1]
    ] * 2
    assert "stop" in [s.phrase for s in verdicts[0].spotted]
    assert not spotter.finish().stop  # nothing fed: no stop


def test_a_transcript_is_a_stop_when_its_words_are_a_stop_phrase_with_a_few_more() -> None:
    from robot.speech.stop_word import is_stop_utterance

    for text in (
        "Stop!",
        "stop right now please",
        "Robot, stop.",
        "Emergency stop now",
        "hey robot halt",
        "Freeze.",
        "Stop the robot.",
        "Stop right there!",
        "halt right away",
        "Stop right here.",
        "Just stop.",
    ):
        assert is_stop_utterance(text), text
    for text in (
        "go to the dock and stop there",
        "stop by the kitchen and get the mug",
        "top",
        "bus stop",
        "",
        "stop the robot from falling over",
        "stop at the table",
        "put the robot on the dock",
        "just stop by the kitchen",
    ):
        assert not is_stop_utterance(text), text


def test_a_stop_heard_as_the_recognisers_second_wording_is_still_a_stop() -> None:
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str, *others: str) -> Transcript:
        return Transcript(text, 0.6, "whisper", False, 1.0, 0.1, others)

    assert transcript_is_stop(heard("Head stop!", "Head top.", "Hey, stop!"))
    assert transcript_is_stop(heard("Stop!"))
    assert not transcript_is_stop(heard("Head to the dock.", "Head to the dock and stop there."))
    assert not transcript_is_stop(heard("Go to the top.", "Go to the stop."))
    # a stop the transcript reads as the end of a walk is not made a stop by a wording that dropped the "then"
    assert not transcript_is_stop(heard("Walk to the counter, then stop.", "Walk to the counter, stop."))
    assert not transcript_is_stop(heard("Go to the dock and stop.", "Go to the dock. Stop."))
    assert transcript_is_stop(heard("Walk to the counter, stop.", "Walk to the counter, then stop."))
    assert not transcript_is_stop(heard("Go to the dock, next stop.", "Go to the dock, stop."))
    assert transcript_is_stop(heard("Immersion should stop right now.", "Emergency stop right now."))


def test_a_stop_after_one_word_whisper_did_not_catch_is_a_stop_but_dont_stop_and_say_stop_are_not() -> None:
    """Whisper wrote "hey stop" in two voices of the fifth held-out set as "He's top.", "Nice stop!" and "High
    stop!" with no stop among its other wordings."""
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str) -> Transcript:
        return Transcript(text, 0.5, "whisper", False, 1.0, 0.1, ())

    for text in ("He's top.", "Nice stop!", "High stop!", "Whoa, halt!", "Okay freeze."):
        assert transcript_is_stop(heard(text)), text
    for text in ("Don't stop!", "Never stop.", "Say stop.", "Then stop.", "Bus stop.", "Go to the top."):
        assert not transcript_is_stop(heard(text)), text


def test_a_stop_whose_last_words_were_misheard_is_a_stop_but_a_stop_somewhere_or_doing_something_is_not() -> None:
    """Whisper heard "stop the robot now" as "Stop the robot out." and "okay, stop now" as "Ok, stop the house."."""
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str) -> Transcript:
        return Transcript(text, 0.5, "whisper", False, 1.0, 0.1, ())

    for text in (
        "Stop the robot out.",
        "Ok, stop the house.",
        "Stop right to help.",
        "Stop! The robot's out.",
        "Stop right, I'm weird.",  # "stop right away"
    ):
        assert transcript_is_stop(heard(text)), text
    for text in (
        "Stop at the dock.",
        "Stop by the counter.",
        "Stop when you get there.",
        "Stop and go to the table.",
        "Stop looking for the mug.",
        "Stop to pick up the bottle.",
        "Stop, then bring me the apple and the mug.",
        "Stop the robot out of the kitchen.",
        "Stop right at the dock.",
        "Stop right, then go to the table.",
    ):
        assert not transcript_is_stop(heard(text)), text


def test_a_stop_whose_first_words_were_misheard_or_a_halt_heard_as_alt_is_a_stop_but_a_command_is_not() -> None:
    """Whisper heard "emergency stop right now" as "Immersion seat stop right now.", "stop now please" as "Stop! No,
    please!" and "halt" as "Alt!" or "Hold!" in the seventh spoken set's voices."""
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str) -> Transcript:
        return Transcript(text, 0.5, "whisper", False, 1.0, 0.1, ())

    for text in (
        "Immersion seat stop right now.",
        "Just stop.",
        "Stop! No, please!",
        "Stop, no robot, please!",
        "Alt!",
        "Hey, Alt!",
        "Head, hold!",
        "Hold it right there.",
        "Okay, out!",
        "Out please!",
        "Hold right here.",
        "Alt right here.",
    ):
        assert transcript_is_stop(heard(text)), text
    for text in (
        "Walk to the dock and stop here.",
        "Don't stop now.",
        "I said stop.",
        "Then you just stop right now.",
        "The red mug stop.",
        "Go to the dock and stop.",
        "Take the mug, hold it.",
        "Hold the mug.",
        "Hold still for three seconds.",
        "Hold on to the bottle.",
        "Get out of the kitchen.",
        "Go out.",
        "Watch out!",
        "Out of the way.",
        "Bus stop please.",
    ):
        assert not transcript_is_stop(heard(text)), text


def test_a_transcript_ending_in_a_stop_clause_is_a_stop_and_a_command_that_stops_somewhere_is_not() -> None:
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str, *others: str) -> Transcript:
        return Transcript(text, 0.6, "whisper", False, 1.0, 0.1, others)

    for text in (
        "Okay, move on, stop!",
        "No, no, stop.",
        "Wait. Stop right now!",
        "Walk to the counter. Stop.",
        "Go to the table, stop right there!",
        "Okay, stop there.",
        "Hey, table, stop there.",
    ):
        assert transcript_is_stop(heard(text)), text
    assert transcript_is_stop(heard("Okay, move, not stop.", "Okay, move. Stop!"))
    for text in (
        "Walk to the counter, then stop.",
        "Go to the table, stop in front of it.",
        "Stop, bite my kitchen and get to the mug.",
        "Fetch the bottle, don't stop on the way.",
        "Go to the dock and stop there.",
        "Go to the table, stop there.",
        "Walk over to the kitchen. Stop here.",
        "Okay, move on.",
        "Halt home.",  # "go home" in the nineteenth set's voices: the tail names where to go
    ):
        assert not transcript_is_stop(heard(text)), text


def test_a_short_utterance_is_a_stop_when_a_wording_further_down_the_beam_is_one_and_a_long_one_is_not() -> None:
    """Whisper heard "halt right there" as "Alt-right hair." with "Hold right there." further down its beam (the
    eleventh spoken set)."""
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str, further: tuple[str, ...], audio_s: float = 1.5) -> Transcript:
        return Transcript(text, 0.4, "whisper", False, audio_s, 0.1, (), (), False, further)

    assert transcript_is_stop(heard("Alt-right hair.", ("Hold right, head.", "Hold right there.")))
    assert transcript_is_stop(heard("The Emergency Seat Stop.", ("The emergency stop.",)))
    assert not transcript_is_stop(heard("Alt-right hair.", ("Hold right there.",), audio_s=5.0))  # a longer command
    assert not transcript_is_stop(heard("Hard to beat the apple.", ("Hand me the bottle.", "Halt!")))  # stopped early
    assert not transcript_is_stop(heard("Call my brother.", ("Called my brother.", "Halt my brother.")))
    assert not transcript_is_stop(heard("Return home now.", ("Return for now.", "Return home, Halt!")))  # said last
    assert not transcript_is_stop(heard("Go to the top.", ("Go to the stop.", "Go to the table and stop there.")))


def test_whispers_further_wordings_are_the_rest_of_each_beam_within_the_margin_once_each() -> None:
    from robot.speech.whisper import Hypothesis, further_wordings

    tiny = [
        Hypothesis("Alt out.", -0.5, -0.5),
        Hypothesis("All that.", -0.7, -0.7),  # an alternative already
        Hypothesis("Halt out.", -1.2, -1.2),
        Hypothesis("Walk out.", -1.8, -1.8),  # too far below tiny's best
    ]
    base = [
        Hypothesis("Halt, now.", -0.9, -0.9),
        Hypothesis("Halt now!", -1.0, -1.0),
        Hypothesis("Hold on.", -1.5, -1.5),
    ]
    # heard again: base's likeliest is the transcript ("Halt now!" is the same words), tiny.en's among the alternatives
    assert further_wordings([tiny, base], ("Halt, now.", "Alt out.", "All that.")) == ("Halt out.", "Hold on.")
    assert further_wordings([tiny[:1]], ("Alt out.",)) == ()


def test_a_stop_said_first_then_a_few_misheard_words_is_a_stop_unless_they_ask_for_something_or_take_it_back() -> None:
    """Whisper heard "stop stop stop" in noise as "Stop! It's time! It's time!" (the thirteenth spoken set)."""
    from robot.speech.asr import Transcript
    from robot.speech.stop_word import transcript_is_stop

    def heard(text: str, audio_s: float = 1.5) -> Transcript:
        return Transcript(text, 0.4, "whisper", False, audio_s, 0.1, ())

    for text in ("Stop! It's time! It's time!", "Freeze. The robot is falling.", "Halt! Oh my goodness."):
        assert transcript_is_stop(heard(text)), text
    for text in (
        "Stop! Never mind.",
        "Stop, sorry, carry on.",
        "Freeze. Just kidding.",
        "Stop. Go to the kitchen.",
        "Halt! Then pick up the mug.",
        "Stop, no, keep going.",
        "Stop. Bring the apple.",
    ):
        assert not transcript_is_stop(heard(text)), text
    assert not transcript_is_stop(heard("Stop! It's time! It's time!", audio_s=6.0))


def test_whispers_prompt_names_every_thing_and_place_and_the_longer_names_people_use(world) -> None:
    from robot.speech.whisper import world_prompt

    prompt = world_prompt(world.objects, world.places)
    assert prompt.startswith("Stop!")  # the stop words first: whisper expects them
    for name in (*world.objects, *world.places):
        assert name.replace("-", " ") in prompt
    assert "the water bottle" in prompt and "the charging station" in prompt  # aliases of more than one word
    assert prompt.count("the living room table") == 1  # a name said once, whichever table it came from
    assert len(prompt.split()) < 120  # whisper keeps at most 223 tokens of a prompt


def test_the_recognisers_leave_no_files_behind_and_still_hear(world, tmp_path, monkeypatch) -> None:
    # their decoders read the grammar and the stop phrases from files as they are built: a folder kept for the
    # recogniser's life was left in /tmp by every robot process that was killed (190 in a day of test runs here)
    import tempfile

    from robot.speech.stop_word import StopSpotter

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    asr = PocketSphinxASR(world.objects, world.places)
    spotter = StopSpotter(world.objects, world.places)
    assert list(tmp_path.iterdir()) == []
    assert asr.transcribe(synthesize_audio("go to the charging dock", "en-us", 160)).text == "go to the charging dock"
    assert spotter.spot(_padded("stop", "en-us", 160)).stop


def test_a_misheard_verb_is_asked_about_in_the_words_the_audio_supports(whisper) -> None:
    """A recording of the speech bench's (heldout17, seed 47): "walk to the charging station" in a Caribbean voice is
    heard, sure, as "Work to the charging station." The planner cannot read "work to"; the wording with the command's
    opening is among the alternatives, and planned it walks to the dock (the robot asks first)."""
    from harness.planner_cases import DOCK, go, plan_matches
    from harness.spoken_cases import Voice, utterance
    from robot.model.world import generate_world
    from robot.planning.context import PlanningContext
    from robot.planning.heard import first_readable
    from robot.planning.pipeline import PlannerConfig, build_pipeline
    from robot.planning.planner import PlanningError
    from robot.planning.world_context import WorldContext

    planner = build_pipeline(PlannerConfig(backend="rules"))
    context = PlanningContext(WorldContext.from_layout(generate_world(0)))
    heard = whisper.transcribe(utterance("walk to the charging station", Voice("en-029+Gene2", 165), None, 47))
    with pytest.raises(PlanningError):
        planner.plan(heard.text, context)
    wording, planned = first_readable(planner, heard.alternatives, context)
    assert wording == "walk to the charging station", heard
    assert plan_matches(go(DOCK), planned.plan.to_seed_list()), planned.plan


def test_reopened_wordings_follow_the_beams_and_only_those_the_audio_supports_are_kept() -> None:
    from robot.speech.whisper import REOPEN_MARGIN, REOPENED_KEPT, with_reopened

    likely = {"grant me the cup please": -10.0, "grab me the cup please": -12.0, "hand me the cup please": -30.0}

    def likelihoods(texts: list[str]) -> list[float]:
        return [likely.get(t.lower().rstrip(".").replace(",", ""), -10.0 - 2 * REOPEN_MARGIN) for t in texts]

    heard = ("Grant me a cup, please.",)
    kept = with_reopened("Grant me the cup, please.", heard, likelihoods)
    assert kept[: len(heard)] == heard and "grab me the cup please" in kept  # after the beam's own wordings
    assert "hand me the cup please" not in kept  # the audio does not support it
    many = tuple(f"wording {i}" for i in range(19))  # two beams of ten, every wording different
    kept = with_reopened("Grant me the cup, please.", many, likelihoods)
    assert len(kept) <= ALTERNATIVES_KEPT and kept[-1] == "grab me the cup please"
    assert kept[: ALTERNATIVES_KEPT - REOPENED_KEPT] == many[: ALTERNATIVES_KEPT - REOPENED_KEPT]  # the beams' first
    assert with_reopened("", many, likelihoods) == many[: ALTERNATIVES_KEPT - REOPENED_KEPT]


def test_an_unsure_prompt_echo_gives_way_to_what_was_heard_quicker(whisper_twice) -> None:
    """A recording of the speech bench's (heldout20, seed 48): "head over to the counter" in a Caribbean voice in
    noise. Both models wrote a piece of their prompt, "Head to the charging dock.", which plans a walk to the dock;
    heard again 10 % quicker it is "Head to the counter." The echo goes last, and what plans is the walk to the
    counter, asked first (the transcript is not sure)."""
    from harness.planner_cases import COUNTER, go, plan_matches
    from harness.spoken_cases import Voice, utterance
    from robot.model.world import generate_world
    from robot.planning.context import PlanningContext
    from robot.planning.heard import first_readable
    from robot.planning.pipeline import PlannerConfig, build_pipeline

    planner = build_pipeline(PlannerConfig(backend="rules"))
    context = PlanningContext(WorldContext.from_layout(generate_world(0)))
    heard = whisper_twice.transcribe(utterance("head over to the counter", Voice("en-029+Lee", 155, 55), 10.0, 48))
    assert not heard.sure
    assert len(heard.alternatives) <= ALTERNATIVES_KEPT  # what the API takes with a spoken command
    wordings = (heard.text, *heard.alternatives)
    assert "head to the charging dock" not in [w.lower().rstrip(".!") for w in wordings[:3]], heard
    wording, planned = first_readable(planner, wordings, context)
    assert plan_matches(go(COUNTER), planned.plan.to_seed_list()), (wording, heard)


def test_pieces_of_the_prompt_are_echoes_and_go_last() -> None:
    from robot.speech.prompt_echo import PromptEcho
    from robot.speech.whisper import BEAM_WORDINGS_KEPT, STOP_SENTENCE, arranged

    prompt = f"{STOP_SENTENCE} Robot, could you please pick up the red mug from the kitchen counter? Head to the dock."
    is_echo = PromptEcho(prompt, STOP_SENTENCE)
    assert is_echo("Head to the dock.") and is_echo("the red mug from the kitchen")  # a sentence, or a piece of one
    assert is_echo("Counter? Head to the dock!")  # across two sentences
    assert not is_echo("red mug") and not is_echo("the dock")  # shorter than ECHO_MIN_WORDS: what people say
    assert not is_echo("Stop! Halt! Freeze!") and not is_echo("Halt! Freeze! Robot")  # a stop is never an echo
    assert not is_echo("Head to the counter.") and not is_echo("pick up the red cup")
    # a prompt sentence's opening with another ending (heldout23, a Scottish voice: "the bottle, take it to the dock")
    assert is_echo("Robot, could you please pick up the green apple?")
    assert not is_echo("Robot, could you please bring me the apple?")  # four words of the opening: people say that
    assert not is_echo("Could you please pick up the green apple?")  # not the sentence's opening

    beams = tuple(f"wording {i}" for i in range(12))
    text, others = arranged("Head to the dock.", ("Head to the dock", *beams), ["Head to the counter."], is_echo)
    assert text == "wording 0"  # the first wording that is not the prompt said back
    assert others[: BEAM_WORDINGS_KEPT - 2] == beams[1 : BEAM_WORDINGS_KEPT - 1]  # the beams' kept, in their order
    assert others[-2:] == ("Head to the counter.", "Head to the dock.")  # then the quicker hearing's, the echo last
    assert len(others) == BEAM_WORDINGS_KEPT  # the same words twice are one wording
    # every wording an echo: the transcript stays the likeliest
    assert arranged("Head to the dock.", (), ["Head to the dock!"], is_echo) == ("Head to the dock.", ())
    assert arranged("Head to the dock.", (), [], lambda _: False) == ("Head to the dock.", ())
    # the transcript is in English letters: a word the multilingual model wrote in another script stays an alternative
    assert arranged("Head to the dock.", ("都 hold on.", "Hold still."), [], is_echo) == (
        "Hold still.",
        ("都 hold on.", "Head to the dock."),
    )


def test_a_sure_transcript_no_command_of_the_world_gives_way_to_the_wording_that_is(world, whisper_twice) -> None:
    """A recording of the speech bench's (heldout21, seed 129): "go to your home position" in a British voice. tiny.en
    is sure of "Go to your phone position.", which no planner reads; "Go to your home position." is in its beam. Read
    against the world, that is the transcript, and it is not sure: the operator sends it."""
    from harness.spoken_cases import Voice, utterance
    from robot.model.world import generate_world
    from robot.planning.context import PlanningContext
    from robot.planning.pipeline import PlannerConfig, build_pipeline
    from robot.speech.world_reading import WorldReadRecognizer

    audio = utterance("go to your home position", Voice("en-gb+Hugo", 155), None, 129)
    first = whisper_twice.transcribe(audio)
    heard = WorldReadRecognizer(whisper_twice, world).transcribe(audio)
    assert heard.first_heard == first.text and "home" in heard.text.lower() and "home" not in first.text.lower()
    assert not heard.sure and heard.alternatives[0] == first.text
    planner = build_pipeline(PlannerConfig(backend="rules"))
    planned = planner.plan(heard.text, PlanningContext(WorldContext.from_layout(generate_world(0))))
    assert [step.action for step in planned.plan.steps][:1] == ["go_home"]
