// captions_templates.cpp — the caption word tables: templates per content, subjects and adverbs per style.
// Edit here, then regenerate docs/CAPTIONS.md (T2M_UPDATE_DOCS=1 ./test_captions; a test compares them).
#include "models/data/captions.h"

namespace t2m::data {

namespace {

std::vector<CaptionContent> build_contents() {
  std::vector<CaptionContent> c = {
      // ---- shared by dataset-1 and dataset-2 ------------------------------------------------------------------
      {"walk",
       {"{s} walks forward{a}", "{s} is walking forward{a}", "{s} walks straight ahead{a}",
        "{s} takes several steps forward{a}", "{s} walks in a straight line{a}", "{s} moves forward on foot{a}",
        "{s} walks ahead a few paces{a}", "{s} steps forward one foot after the other{a}",
        "{s} goes for a short walk forward{a}"},
       ""},
      {"run",
       {"{s} runs forward{a}", "{s} is running forward{a}", "{s} jogs forward{a}", "{s} runs straight ahead{a}",
        "{s} runs a short distance{a}", "{s} breaks into a run{a}", "{s} is jogging ahead{a}",
        "{s} runs forward for a few strides{a}"},
       ""},
      // ---- dataset-1 ----------------------------------------------------------------------------------------------
      {"dash",
       {"{s} sprints forward{a}", "{s} dashes ahead{a}", "{s} runs forward as fast as possible{a}",
        "{s} makes a quick dash forward{a}", "{s} is sprinting straight ahead{a}", "{s} rushes forward at full speed{a}",
        "{s} bolts forward{a}", "{s} races ahead{a}"},
       ""},
      {"walk-back",
       {"{s} walks backward{a}", "{s} is walking backwards{a}", "{s} steps backward{a}",
        "{s} takes several steps back{a}", "{s} moves backwards on foot{a}", "{s} backs up{a}",
        "{s} walks in reverse{a}", "{s} retreats a few steps backward{a}"},
       ""},
      {"walk-left",
       {"{s} walks to the left{a}", "{s} is walking toward the left{a}", "{s} moves to the left on foot{a}",
        "{s} walks leftward{a}", "{s} heads off to the left{a}", "{s} takes several steps to the left{a}",
        "{s} walks over to the left side{a}", "{s} turns and walks to the left{a}"},
       ""},
      {"walk-right", {}, "walk-left"},
      {"bow",
       {"{s} bows{a}", "{s} takes a bow{a}", "{s} bends forward at the waist in a bow{a}", "{s} is bowing{a}",
        "{s} bows to someone in front{a}", "{s} leans forward in a bow and straightens up again{a}",
        "{s} gives a bow{a}", "{s} bows the head and upper body{a}"},
       ""},
      {"bye",
       {"{s} waves goodbye{a}", "{s} says goodbye with a wave{a}", "{s} waves a hand to say bye{a}",
        "{s} is waving goodbye{a}", "{s} raises a hand and waves farewell{a}", "{s} bids farewell with a hand wave{a}",
        "{s} waves bye to someone{a}", "{s} lifts an arm and waves goodbye{a}"},
       ""},
      {"guide",
       {"{s} gestures to show the way{a}", "{s} guides someone with an outstretched arm{a}",
        "{s} points the way with a hand{a}", "{s} motions for someone to go this way{a}",
        "{s} extends an arm to guide someone{a}", "{s} shows someone where to go{a}",
        "{s} makes a guiding gesture with the arm{a}", "{s} directs someone with a sweep of the hand{a}"},
       ""},
      {"byebye",
       {"{s} waves bye-bye{a}", "{s} is waving bye-bye{a}", "{s} waves goodbye over and over{a}",
        "{s} says bye-bye with a big wave{a}", "{s} waves farewell again and again{a}",
        "{s} keeps waving goodbye{a}", "{s} gives a big goodbye wave{a}", "{s} waves a long bye-bye to someone{a}"},
       ""},
      {"respond",
       {"{s} responds to someone{a}", "{s} answers a call with a gesture{a}", "{s} reacts to being called{a}",
        "{s} turns and responds{a}", "{s} acknowledges someone{a}", "{s} replies with a gesture{a}",
        "{s} responds to a call by raising a hand{a}", "{s} gestures in response to someone{a}"},
       ""},
      {"call",
       {"{s} calls someone over{a}", "{s} beckons someone to come{a}", "{s} waves someone over{a}",
        "{s} calls out to someone{a}", "{s} gestures for someone to come closer{a}",
        "{s} summons someone with a hand{a}", "{s} is calling to someone{a}", "{s} motions someone to come here{a}"},
       ""},
      {"punch",
       {"{s} punches{a}", "{s} throws a punch{a}", "{s} punches forward{a}", "{s} strikes with a fist{a}",
        "{s} throws a punch into the air{a}", "{s} is punching forward{a}", "{s} jabs with a fist{a}",
        "{s} hits forward with a punch{a}"},
       ""},
      {"kick",
       {"{s} kicks{a}", "{s} kicks forward{a}", "{s} kicks with one leg{a}", "{s} throws a kick{a}",
        "{s} is kicking forward{a}", "{s} kicks out with a foot{a}", "{s} delivers a kick{a}",
        "{s} lifts a leg and kicks{a}"},
       ""},
      {"slash",
       {"{s} slashes with a sword{a}", "{s} swings a sword{a}", "{s} makes a slashing motion{a}",
        "{s} cuts through the air with a blade{a}", "{s} slashes forward{a}", "{s} swings an imaginary sword{a}",
        "{s} strikes with a slashing cut{a}", "{s} is slashing with a weapon{a}"},
       ""},
      {"dance-long",
       {"{s} dances{a}", "{s} performs a long dance{a}", "{s} is dancing for a while{a}",
        "{s} dances a long routine{a}", "{s} moves to music in a long dance{a}",
        "{s} performs an extended dance routine{a}", "{s} dances around{a}", "{s} keeps dancing{a}"},
       ""},
      {"dance-short",
       {"{s} performs a short dance{a}", "{s} does a quick dance{a}", "{s} dances a short routine{a}",
        "{s} does a few dance moves{a}", "{s} is dancing{a}", "{s} dances for a moment{a}",
        "{s} breaks into a short dance{a}", "{s} performs a brief dance routine{a}"},
       ""},
      // ---- dataset-2 ----------------------------------------------------------------------------------------------
      {"walk-turn-left",
       {"{s} walks forward and turns left{a}", "{s} walks and turns to the left{a}",
        "{s} makes a left turn while walking{a}", "{s} is walking and turning left{a}",
        "{s} turns left while walking{a}", "{s} walks in a curve to the left{a}",
        "{s} walks forward and veers left{a}", "{s} walks ahead and turns toward the left{a}"},
       ""},
      {"walk-turn-right", {}, "walk-turn-left"},
      {"wave-both-hands",
       {"{s} waves both hands{a}", "{s} is waving with both hands{a}", "{s} raises both arms and waves{a}",
        "{s} waves both arms{a}", "{s} waves with both hands at someone{a}",
        "{s} greets someone by waving both hands{a}", "{s} lifts both hands and waves them{a}",
        "{s} waves hello with both hands{a}"},
       ""},
      {"wave-left-hand",
       {"{s} waves the left hand{a}", "{s} waves with the left hand{a}", "{s} is waving the left hand{a}",
        "{s} raises the left hand and waves{a}", "{s} waves with the left arm{a}",
        "{s} greets someone by waving the left hand{a}", "{s} lifts the left hand and waves it{a}",
        "{s} waves hello with the left hand{a}"},
       ""},
      {"wave-right-hand", {}, "wave-left-hand"},
      {"raise-up-both-hands",
       {"{s} raises both hands{a}", "{s} lifts both arms up{a}", "{s} raises both arms above the head{a}",
        "{s} puts both hands up{a}", "{s} is raising both hands{a}", "{s} holds both hands up in the air{a}",
        "{s} lifts both hands overhead{a}", "{s} throws both arms up{a}"},
       ""},
      {"raise-up-left-hand",
       {"{s} raises the left hand{a}", "{s} lifts the left arm up{a}", "{s} raises the left arm above the head{a}",
        "{s} puts the left hand up{a}", "{s} is raising the left hand{a}", "{s} holds the left hand up in the air{a}",
        "{s} lifts the left hand overhead{a}", "{s} puts up the left hand{a}"},
       ""},
      {"raise-up-right-hand", {}, "raise-up-left-hand"},
  };
  // The "-right" contents are the left/right swap of their "-left" partners (mirror consistency by construction).
  for (auto& e : c) {
    if (e.mirrored_from.empty()) continue;
    for (const auto& src : c)
      if (src.label == e.mirrored_from)
        for (const auto& t : src.templates) e.templates.push_back(swap_left_right(t));
  }
  return c;
}

std::vector<CaptionStyle> build_styles() {
  return {
      {"normal", {"a person", "someone", "a man", "a woman"}, {"", "", "normally", "casually", "in a relaxed way"}},
      {"happy", {"a happy person", "a cheerful person", "a joyful person"},
       {"happily", "cheerfully", "joyfully", "in a happy mood"}},
      {"sad", {"a sad person", "an unhappy person", "a gloomy person"}, {"sadly", "gloomily", "dejectedly", "in a sad way"}},
      {"angry", {"an angry person", "a furious person", "an irritated person"},
       {"angrily", "furiously", "in an angry manner"}},
      {"proud", {"a proud person", "a self-assured person", "a haughty person"},
       {"proudly", "with pride", "with a proud posture", "confidently"}},
      {"not-confident", {"an insecure person", "a timid person", "a shy person", "an unconfident person"},
       {"timidly", "hesitantly", "without confidence", "shyly", "nervously"}},
      {"masculinity", {"a masculine person", "a macho person", "a manly person"},
       {"in a masculine way", "in a manly manner", "with a macho swagger"}},
      {"feminine", {"a feminine person", "a graceful, feminine person"},
       {"in a feminine way", "gracefully", "elegantly", "in a ladylike manner"}},
      {"childish", {"a childish person", "a child-like person", "a playful person"},
       {"childishly", "like a child", "playfully"}},
      {"old", {"an old person", "an elderly person", "an aged person"},
       {"slowly, like an old person", "stiffly", "feebly", "like an old person"}},
      {"tired", {"a tired person", "a weary person", "a worn-out person"},
       {"tiredly", "wearily", "sluggishly", "like someone who is tired"}},
      {"active", {"an energetic person", "an active person", "a lively person"},
       {"energetically", "actively", "vigorously", "in a lively way"}},
      {"musical", {"a theatrical performer", "a person in a musical"},
       {"theatrically", "like in a musical", "with dramatic, musical flair"}},
      {"giant", {"a giant", "a huge, heavy giant", "a giant-like person"},
       {"like a giant", "heavily, like a giant", "with huge, heavy movements"}},
      {"chimpira", {"a thug", "a street punk", "a delinquent"},
       {"like a thug", "in a swaggering, thuggish way", "like a street punk"}},
      {"elderly", {"an elderly person", "an old person", "a senior citizen"},
       {"slowly, like an elderly person", "stiffly", "feebly", "like an elderly person"}},
      {"exhausted", {"an exhausted person", "a fatigued person", "a weary person"},
       {"wearily", "in an exhausted way", "sluggishly", "with exhaustion"}},
      {"masculine", {"a masculine person", "a macho person", "a manly person"},
       {"in a masculine way", "in a manly manner", "with a macho swagger"}},
      {"youthful", {"a young person", "a youthful person", "a young adult"},
       {"youthfully", "in a youthful way", "with youthful energy"}},
  };
}

}  // namespace

const std::vector<CaptionContent>& caption_contents() {
  static const std::vector<CaptionContent> c = build_contents();
  return c;
}

const std::vector<CaptionStyle>& caption_styles() {
  static const std::vector<CaptionStyle> s = build_styles();
  return s;
}

const std::vector<std::string>& caption_neutral_subjects() {
  static const std::vector<std::string> s = {"a person", "someone", "the person", "a human"};
  return s;
}

}  // namespace t2m::data
